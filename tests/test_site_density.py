"""A fence is judged with the envelope the aircraft has at the site's air density, not its sea-level one."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from aircraft.profile import load_profile
from geofence.geometry.geodesy import LocalFrame
from geofence.margins.boundary_shift import worst_case_lateral_shift_m
from geofence.physics.dynamics import envelope_at_density, isa_density_ratio
from geofence.validation import ConfigError
from scenarios.definition.schema import parse_scenario

LAT_DEG, LON_DEG = 46.5, 9.8
HIGH_SITE_M = 2780.0
C172X = load_profile("c172x").envelope


def c172x_square(ground_alt_m: float, side_m: float, allow: tuple[str, ...] = ()) -> dict:
    """A c172x air start at 300 m AGL in the middle of a square keep-in of ``side_m``."""
    frame = LocalFrame(LAT_DEG, LON_DEG, ground_alt_m)
    h = side_m / 2.0
    corners = [frame.to_geodetic(e, n, ground_alt_m)[:2] for e, n in ((-h, -h), (h, -h), (h, h), (-h, h))]
    doc = {
        "name": "c172x_high_site",
        "aircraft": "c172x",
        "duration_s": 60,
        "start": {"lat_deg": LAT_DEG, "lon_deg": LON_DEG, "ground_alt_m": ground_alt_m, "agl_m": 300, "heading_deg": 0},
        "pilot": {"type": "scripted", "segments": [{"duration_s": 60, "course_deg": 0, "speed": "max", "climb": "hold"}]},
        "geofence": {"fence": {"keep_in": [list(c) for c in corners], "ceiling_m": 600}},
    }
    if allow:
        doc["allow"] = list(allow)
    return doc


def shift_m(ground_alt_m: float) -> float:
    """The worst-case lateral shift of the c172x at the start altitude of :func:`c172x_square`."""
    return worst_case_lateral_shift_m(envelope_at_density(C172X, isa_density_ratio(ground_alt_m + 300.0)), 0.0)


# A square that fits the sea-level turn but not the turn at 2,780 m: inradius half-way between the two shifts.
SIDE_M = shift_m(0.0) + shift_m(HIGH_SITE_M)


def test_the_high_site_needs_a_wider_fence_than_sea_level():
    """The oracle: at sigma ~0.74 the true airspeed is ~16 % higher and the turn radius ~35 % larger."""
    sigma = isa_density_ratio(HIGH_SITE_M + 300.0)
    assert sigma == pytest.approx(0.737, abs=0.01)
    assert shift_m(HIGH_SITE_M) > 1.2 * shift_m(0.0)


def test_a_fence_too_small_at_the_site_is_refused_with_the_numbers():
    with pytest.raises(ConfigError) as exc:
        parse_scenario(c172x_square(HIGH_SITE_M, SIDE_M), where="high.yaml")
    msg = str(exc.value)
    assert msg.startswith("high.yaml: geofence.fence: at the site's air density (ISA sigma 0.74 at 3,080 m)")
    assert "fence_too_small_at_site" in msg and "\n" not in msg
    shift, inradius = (float(m) for m in re.findall(r"(?:shift|inradius) ([0-9.]+) m", msg))
    assert shift == pytest.approx(shift_m(HIGH_SITE_M), abs=0.05)
    assert inradius == pytest.approx(SIDE_M / 2.0, abs=1.0)


def test_the_same_fence_at_sea_level_validates():
    sc = parse_scenario(c172x_square(0.0, SIDE_M), where="low.yaml")
    assert not sc.warnings


def test_allow_flies_it_with_a_warning():
    sc = parse_scenario(c172x_square(HIGH_SITE_M, SIDE_M, allow=("fence_too_small_at_site",)), where="high.yaml")
    assert any("site's air density" in w for w in sc.warnings)


@settings(max_examples=30, deadline=None)
@given(low_m=st.floats(0.0, 3500.0), extra_m=st.floats(0.0, 1500.0), side_fraction=st.floats(0.8, 1.6))
def test_refusal_is_monotone_in_site_altitude(low_m, extra_m, side_fraction):
    """A fence refused at one site is refused at every higher site (thinner air never makes a fence fit)."""
    side = side_fraction * SIDE_M

    def refused(alt: float) -> bool:
        try:
            parse_scenario(c172x_square(alt, side), where="p.yaml")
        except ConfigError:
            return True
        return False

    if refused(low_m):
        assert refused(low_m + extra_m)


def test_validate_refuses_in_one_line_with_exit_2(tmp_path):
    path = tmp_path / "high.yaml"
    path.write_text(yaml.safe_dump(c172x_square(HIGH_SITE_M, SIDE_M)))
    proc = subprocess.run(
        [sys.executable, "-m", "scenarios.app.cli", "validate", str(path)], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "site's air density" in lines[0] and "Traceback" not in proc.stderr
