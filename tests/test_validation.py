"""The validation kit (geofence/validation.py): one error type, one-line messages naming the field."""

import math
from enum import StrEnum

import pytest
from hypothesis import given
from hypothesis import strategies as st

from aircraft.jsbsim_model import UnknownAircraftError
from aircraft.profile import ProfileError
from analysis.logs import LogError
from geofence.config import GeofenceConfigError
from geofence.fence import FenceError
from geofence.validation import (
    ConfigError,
    direction_deg,
    enum_value,
    integer,
    number,
    number_range,
    reject_unknown_keys,
    require_mapping,
    string,
)


class Colour(StrEnum):
    RED = "red"
    GREEN = "green"


def one_line(exc: pytest.ExceptionInfo, where: str) -> str:
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith(f"{where}: ")
    return msg


def test_every_user_error_type_is_a_config_error():
    """The CLI catches ConfigError only: every parser's error type must subclass it."""
    for t in (GeofenceConfigError, FenceError, ProfileError, UnknownAircraftError, LogError):
        assert issubclass(t, ConfigError), t


@given(st.floats(allow_nan=False, allow_infinity=False) | st.integers(-(10**6), 10**6))
def test_number_accepts_finite_numbers(x):
    assert number(x, "f.yaml: a") == float(x)


@pytest.mark.parametrize(
    "bad, problem",
    [
        (True, "expected a number, got a boolean True"),
        ("3", "expected a number, got a string '3'"),
        (None, "expected a number, got nothing None"),
        (math.nan, "must be a finite number"),
        (math.inf, "must be a finite number"),
    ],
)
def test_number_refuses_non_numbers_in_one_line(bad, problem):
    with pytest.raises(ConfigError) as exc:
        number(bad, "f.yaml: a.b")
    assert problem in one_line(exc, "f.yaml: a.b")


def test_number_bounds_and_inf():
    assert number(math.inf, "w", allow_inf=True) == math.inf
    with pytest.raises(ConfigError, match=r"w: must be > 0, got 0"):
        number(0, "w", strictly_positive=True)
    with pytest.raises(ConfigError, match=r"w: must be >= 1, got 0.5"):
        number(0.5, "w", minimum=1)
    with pytest.raises(ConfigError, match=r"w: must be <= 1, got 2"):
        number(2, "w", maximum=1)


def test_integer_range_direction_string():
    assert integer(3, "w", minimum=0) == 3
    for bad in (True, 2.0, "2"):
        with pytest.raises(ConfigError, match="expected an integer"):
            integer(bad, "w")
    assert number_range([1, 2], "w") == (1.0, 2.0) and number_range(3, "w") == (3.0, 3.0)
    with pytest.raises(ConfigError, match=r"w: low must be <= high"):
        number_range([2, 1], "w")
    assert direction_deg(360, "w") == 0.0
    with pytest.raises(ConfigError, match=r"w: 'x' is not one of a, b"):
        string("x", "w", choices=["a", "b"])


def test_mapping_and_unknown_keys():
    with pytest.raises(ConfigError, match=r"w: expected a mapping \(key: value\), got a list"):
        require_mapping([1], "w")
    with pytest.raises(ConfigError) as exc:
        reject_unknown_keys({"speed_mp": 1}, ("speed_mps", "from_deg"), "f.yaml: wind")
    assert one_line(exc, "f.yaml: wind.speed_mp").endswith("unknown key (did you mean 'speed_mps'? allowed: from_deg, speed_mps)")
    with pytest.raises(ConfigError, match=r"^f.yaml: colour: unknown key"):
        reject_unknown_keys({"colour": 1}, ("name",), "f.yaml: (top level)")


def test_enum_value_lists_the_members():
    assert enum_value("red", "w", Colour) is Colour.RED
    assert enum_value(Colour.GREEN, "w", Colour) is Colour.GREEN
    with pytest.raises(ConfigError, match=r"^w: 'blue' is not one of red, green$"):
        enum_value("blue", "w", Colour)


@given(st.text(max_size=12))
def test_unknown_key_messages_stay_one_line_whatever_the_key(key):
    """A key from the file (newlines, quotes, anything) cannot break the one-line message."""
    if key == "name":
        return
    with pytest.raises(ConfigError) as exc:
        reject_unknown_keys({key: 1}, ("name",), "f.yaml: (top level)")
    msg = str(exc.value)
    assert "\n" not in msg and "\r" not in msg and msg.startswith("f.yaml: ")
