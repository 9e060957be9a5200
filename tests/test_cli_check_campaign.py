"""The CLI's pre-flight check and campaign commands: verdicts with exit codes, bad input with one line and exit 2."""

import subprocess
import sys

from geofence.geometry.geodesy import LocalFrame

FRAME = LocalFrame(47.3, 8.5, 450.0)


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "scenarios.app.cli", *args], capture_output=True, text=True, timeout=300)


def mission_scenario(tmp_path, last_e_m):
    corners = [(-200.0, -200.0), (200.0, -200.0), (200.0, 200.0), (-200.0, 200.0)]
    keep_in = [list(FRAME.to_geodetic(e, n, 0.0)[:2]) for e, n in corners]
    wp = [FRAME.to_geodetic(e, n, 0.0)[:2] for e, n in ((0.0, 100.0), (last_e_m, 100.0))]
    items = "\n".join(f"    - {{type: waypoint, lat_deg: {lat}, lon_deg: {lon}, agl_m: 30}}" for lat, lon in wp)
    p = tmp_path / f"m{int(last_e_m)}.yaml"
    p.write_text(f"""name: m{int(last_e_m)}
aircraft: F450RD
duration_s: 100
start: {{lat_deg: 47.3, lon_deg: 8.5, ground_alt_m: 450, agl_m: 30}}
mission:
  items:
{items}
geofence:
  fence: {{keep_in: {keep_in}, ceiling_m: 80}}
""")
    return p


def test_check_passes_a_comfortable_mission_and_flags_one_that_ends_at_the_fence(tmp_path):
    ok = run_cli("check", str(mission_scenario(tmp_path, 100.0)))
    assert ok.returncode == 0 and "passed" in ok.stdout, ok.stdout + ok.stderr
    bad = run_cli("check", str(mission_scenario(tmp_path, 197.0)))
    assert bad.returncode == 1, bad.stdout + bad.stderr
    assert "leg" in bad.stdout and "keep_in edge" in bad.stdout


def test_check_refuses_a_missing_file_with_one_line(tmp_path):
    r = run_cli("check", str(tmp_path / "nope.yaml"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr


def test_campaign_generate_and_report_refuse_bad_folders(tmp_path):
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x.yaml").write_text("name: x\n")
    r = run_cli("campaign", "generate", str(tmp_path / "full"), "--cases", "2")
    assert r.returncode == 2 and "new or empty folder" in r.stderr
    r = run_cli("campaign", "report", str(tmp_path / "results"), "--campaign", str(tmp_path / "full"))
    assert r.returncode == 2 and "results.csv" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("campaign", "generate", str(tmp_path / "new"), "--cases", "2", "--seed", "3")
    assert r.returncode == 0 and (tmp_path / "new" / "campaign.json").is_file()
    assert len(list((tmp_path / "new").glob("*.yaml"))) == 6
    r = run_cli("campaign", "generate", str(tmp_path / "bad"), "--cases", "2", "--platforms", "F450,Spitfire")
    assert r.returncode == 2 and "'Spitfire'" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("campaign", "generate", str(tmp_path / "bad2"), "--cases", "2", "--families", "box,towns")
    assert r.returncode == 2 and r.stderr.strip().splitlines() == [
        "error: --families: unknown family 'towns' (known: box, l_fence, u_fence, star, acute, corridor, keep_out, "
        "ceiling, floor_gaps, circle, city, random)"
    ]
    assert not (tmp_path / "bad2").exists() or not any((tmp_path / "bad2").iterdir())
    r = run_cli("campaign", "generate", str(tmp_path / "tern"), "--cases", "2", "--platforms", "Tern")
    assert r.returncode == 0
    assert {
        line.split(":", 1)[1].strip()
        for f in (tmp_path / "tern").glob("*.yaml")
        for line in f.read_text().splitlines()
        if line.startswith("aircraft:")
    } == {"Tern"}


def test_validate_models_refuses_an_unknown_model_before_flying():
    r = run_cli("validate-models", "--models", "Nope", "--out", "unused.md")
    assert r.returncode == 2 and r.stdout == "" and "no platform profile for aircraft 'Nope'" in r.stderr
