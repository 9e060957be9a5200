"""A model of ours derived from another one (``NAME.derive.xml``) is the base with exactly the appended elements."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from aircraft.jsbsim_model import (
    JSBSimModel,
    available_models,
    derive_model_xml,
    model_folder,
)
from geofence.validation import ConfigError


def test_c172w_is_the_wheel_c172x_plus_one_drag_term():
    folder = model_folder("C172W")
    assert "C172W" in available_models()
    base, derived = derive_model_xml(folder / "C172W.derive.xml")
    assert base == "c172x"
    wheel = ET.parse(model_folder("c172x") / "c172x.xml").getroot()
    names = lambda root: [f.get("name") for f in root.find("aerodynamics/axis[@name='DRAG']").iter("function")]  # noqa: E731
    assert names(derived) == names(wheel) + ["aero/coefficient/CDprop-windmill"]
    assert "geofence-testbed" in derived.find("fileheader/author").text
    # everything else is the wheel's, element for element
    for tag in ("metrics", "mass_balance", "ground_reactions", "propulsion", "flight_control"):
        assert ET.tostring(derived.find(tag)) == ET.tostring(wheel.find(tag))


def test_c172w_loads_and_its_term_acts_only_with_the_throttle_closed():
    m = JSBSimModel("C172W")
    try:
        fdm = m.fdm
        fdm["ic/h-sl-ft"] = 3000.0
        fdm["ic/vc-kts"] = 70.0
        fdm.run_ic()
        for throttle, expect_on in ((0.0, True), (0.5, False)):
            fdm["fcs/throttle-cmd-norm"] = throttle
            for _ in range(12):
                fdm.run()
            drag_lbf = fdm["aero/coefficient/CDprop-windmill"]
            qbar_psf = fdm["aero/qbar-psf"]
            if expect_on:
                assert drag_lbf == pytest.approx(qbar_psf * 30.68 * 0.25 * (1.0 - fdm["fcs/throttle-pos-norm"] / 0.2), rel=1e-6)
                assert drag_lbf > 50.0
            else:
                assert drag_lbf == 0.0
    finally:
        m.close()


@pytest.mark.parametrize(
    "body, problem",
    [
        ('<derive base="c172x"><append to="aerodynamics/axis[@name=\'NOPE\']"><x/></append></derive>', "matches 0"),
        ('<derive base="c172x"><replace/></derive>', "unknown element <replace>"),
        ("<derive/>", "root must be"),
    ],
)
def test_a_bad_derivation_is_refused_with_its_file_and_problem(tmp_path, body, problem):
    f = tmp_path / "X.derive.xml"
    f.write_text(body)
    with pytest.raises(ConfigError, match=problem) as exc:
        derive_model_xml(f)
    assert str(f) in str(exc.value)
