"""The validation kit (geofence/validation.py): one error type, one-line messages naming the field."""

import math
from dataclasses import dataclass, field
from enum import Enum, StrEnum

import pytest
from hypothesis import given
from hypothesis import strategies as st

from aircraft.jsbsim_model import UnknownAircraftError
from aircraft.profile import ProfileError
from analysis.formats.logs import LogError, LogFenceDistanceError, LogIntegrityError
from geofence.geometry.fence import FenceError
from geofence.unit.config import GeofenceConfigError
from geofence.validation import (
    ConfigError,
    boolean,
    direction_deg,
    enum_value,
    field_default,
    integer,
    latitude,
    longitude,
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
    for t in (
        GeofenceConfigError,
        FenceError,
        ProfileError,
        UnknownAircraftError,
        LogError,
        LogIntegrityError,
        LogFenceDistanceError,
    ):
        assert issubclass(t, ConfigError), t
    assert issubclass(ConfigError, ValueError)


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


def test_boolean_accepts_only_true_and_false():
    assert boolean(True, "w") is True and boolean(False, "w") is False
    for bad in (1, 0, "yes", None):
        with pytest.raises(ConfigError) as exc:
            boolean(bad, "f.yaml: a.flag")
        assert "expected true or false" in one_line(exc, "f.yaml: a.flag")


@given(st.floats(-90, 90), st.floats(-180, 180))
def test_latitude_and_longitude_accept_the_globe(lat, lon):
    assert latitude(lat, "w") == lat and longitude(lon, "w") == lon


@pytest.mark.parametrize(
    "read, bad, problem",
    [
        (latitude, 90.5, "must be <= 90, got 90.5"),
        (latitude, -91, "must be >= -90, got -91"),
        (longitude, 180.5, "must be <= 180, got 180.5"),
        (longitude, -200, "must be >= -180, got -200"),
        (latitude, math.nan, "must be a finite number, got nan"),
        (longitude, -math.inf, "must be a finite number, got -inf"),
        (latitude, True, "expected a number, got a boolean True"),
    ],
)
def test_latitude_and_longitude_refuse_off_the_globe(read, bad, problem):
    with pytest.raises(ConfigError) as exc:
        read(bad, "f.yaml: start.lat_deg")
    assert one_line(exc, "f.yaml: start.lat_deg").endswith(problem)


def test_integer_refuses_below_minimum_and_string_refuses_empty():
    with pytest.raises(ConfigError, match=r"^w: must be >= 1, got 0$"):
        integer(0, "w", minimum=1)
    for bad in ("", None, 3):
        with pytest.raises(ConfigError, match=r"^w: expected a non-empty string"):
            string(bad, "w")


def test_direction_and_range_refuse_nan_and_out_of_range():
    for bad in (math.nan, -1, 361, True):
        with pytest.raises(ConfigError, match=r"^w: "):
            direction_deg(bad, "w")
    with pytest.raises(ConfigError, match=r"^w\[1\]: must be a finite number"):
        number_range([1, math.inf], "w")
    with pytest.raises(ConfigError, match=r"^w: expected a number or a \[low, high\] pair, got a list of 3"):
        number_range([1, 2, 3], "w")


def test_enum_value_refuses_other_types_and_names():
    for bad in (None, 1, "RED", "Colour.RED"):
        with pytest.raises(ConfigError, match=r"is not one of red, green$"):
            enum_value(bad, "w", Colour)


def test_field_default_reads_the_dataclass():
    @dataclass
    class D:
        a: int
        b: float = 2.5
        c: list = field(default_factory=lambda: [1])

    assert field_default(D, "b") == 2.5 and field_default(D, "c") == [1]
    with pytest.raises(KeyError):
        field_default(D, "a")


def config_enums() -> list[type[Enum]]:
    from geofence.geometry.fence import AltitudeReference
    from geofence.unit.config import MultirotorLaw, StateSource, Trigger, TurbulenceSource
    from scenarios.definition.schema import SegmentEnd, SpeedDraw
    from wind.config import GustOnset

    return [Trigger, MultirotorLaw, StateSource, TurbulenceSource, AltitudeReference, SegmentEnd, SpeedDraw, GustOnset]


@pytest.mark.parametrize("enum_type", config_enums(), ids=lambda t: t.__name__)
def test_config_enums_are_plain_strings_with_a_docstring_per_member(enum_type):
    """Members compare, hash and print as their value (summary.json, results.csv, f-strings), and differ."""
    members = list(enum_type)
    assert len(set(members)) == len(members) == len({m.value for m in members})
    for m in members:
        assert isinstance(m, str) and m == m.value and hash(m) == hash(m.value) and str(m) == f"{m}" == m.value
        assert all(m != other for other in members if other is not m)
        assert enum_value(m.value, "w", enum_type) is m
    source = __import__("inspect").getsource(enum_type)
    assert source.count('"""') >= 2 * (len(members) + 1), f"{enum_type.__name__}: a docstring per member"
