"""The ``geofence-testbed`` command line.

Subcommands:

* ``run SCENARIO.yaml... --out DIR``: fly scenarios, write trajectory.csv + summary.json each.
* ``validate SCENARIO.yaml...``: check scenario files without flying them.
* ``list``: the aircraft that can fly and the shipped example scenarios.

Bad input (a missing or malformed file, an unknown aircraft, a value out of
range) prints one line ``error: <file>: <field>: <problem>`` on stderr and
exits with code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

EXIT_BAD_INPUT = 2
EXIT_FLIGHT_FAILED = 1
EXIT_INTERRUPTED = 130

SHIPPED_SCENARIOS = Path(__file__).parent


def _user_errors() -> tuple[type[BaseException], ...]:
    from aircraft.jsbsim_model import UnknownAircraftError
    from aircraft.profile import ProfileError
    from scenarios.errors import ConfigError

    return (ConfigError, ProfileError, UnknownAircraftError)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="geofence-testbed",
        description=(
            "Fly small-UAS geofencing scenarios on JSBSim (multicopter and fixed-wing), "
            "under wind, turbulence and gusts, and write trajectories and summaries."
        ),
        epilog="Example: geofence-testbed run scenarios/multicopter_survey_calm.yaml --out out/",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser(
        "run",
        help="fly one or more scenario files",
        description=(
            "Fly each SCENARIO.yaml in closed loop and write DIR/<scenario-name>/trajectory.csv "
            "(one row per control step: time s, lat/lon deg, alt m, ENU position m, ground velocity m/s, "
            "attitude deg, pilot and commanded sticks, geofence mode) and DIR/<scenario-name>/summary.json "
            "(completed, mission_progress, sim_time_s, wall_time_s, ...). Exit code 0 if every flight "
            "completed, 1 if one did not, 2 on bad input."
        ),
    )
    run.add_argument("scenarios", nargs="+", type=Path, metavar="SCENARIO.yaml", help="scenario file(s) to fly")
    run.add_argument("--out", type=Path, default=Path("out"), metavar="DIR", help="output folder (default: ./out)")
    run.add_argument("--quiet", action="store_true", help="no progress display, only the final lines")
    run.add_argument("--no-plot", action="store_true", help="skip flight.png/flight.svg (ground track, altitude, speed)")

    val = sub.add_parser("validate", help="check scenario files without flying", description="Load and validate scenario files; print one line per file.")
    val.add_argument("scenarios", nargs="+", type=Path, metavar="SCENARIO.yaml")

    sub.add_parser("list", help="list flyable aircraft and shipped scenarios", description="List aircraft that have a platform profile, and the example scenarios shipped with the testbed.")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "validate":
            return _cmd_validate(args)
        if args.command == "list":
            return _cmd_list()
    except _user_errors() as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("interrupted: finished results are kept", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_BAD_INPUT  # pragma: no cover - argparse guarantees a command


def _cmd_validate(args) -> int:
    from scenarios.schema import load_scenario

    for path in args.scenarios:
        sc = load_scenario(path)
        print(f"ok: {path}: {sc.name} ({sc.aircraft}, {sc.pilot.kind}, {sc.duration_s:g} s)")
    return 0


def _cmd_list() -> int:
    from aircraft.profile import load_profile, available_profiles

    print("aircraft (platform profiles):")
    for model in available_profiles():
        p = load_profile(model)
        print(f"  {model:10s} {p.kind.value:11s} cruise {p.envelope.cruise_speed_mps:.0f} m/s")
    print("shipped scenarios:")
    for path in sorted(SHIPPED_SCENARIOS.glob("*.yaml")):
        print(f"  {path}")
    return 0


def _cmd_run(args) -> int:
    from scenarios.runner import run_scenario
    from scenarios.schema import load_scenario

    scenarios = [load_scenario(p) for p in args.scenarios]  # validate everything before flying anything
    failed = 0
    for sc in scenarios:
        bar = _progress(sc, quiet=args.quiet)
        try:
            result = run_scenario(sc, args.out, on_step=bar.update if bar else None)
        finally:
            if bar:
                bar.close()
        if not args.no_plot:
            _plot(result, args.out)
        s = result.summary
        status = "completed" if s["completed"] else "NOT completed"
        extra = f" error: {s['error']}" if s.get("error") else ""
        print(
            f"{sc.name}: {status}, mission {s['mission_progress']}, {s['sim_time_s']:.1f} s simulated "
            f"in {s['wall_time_s']:.1f} s -> {args.out / sc.name}{extra}"
        )
        failed += not s["completed"]
    return EXIT_FLIGHT_FAILED if failed else 0


def _plot(result, out_dir: Path) -> None:
    from analysis.plots import plot_flight

    rec = result.recorder
    traj = {name: rec.column(name) for name in ("time_s", "east_m", "north_m", "agl_m", "ground_speed_mps", "airspeed_mps", "wind_east_mps", "wind_north_mps", "geofence_mode")}
    plot_flight(
        traj, Path(out_dir) / result.scenario.name / "flight", f"{result.scenario.name} ({result.scenario.aircraft})",
        fence=result.extras.get("fence"), envelope=result.scenario.profile.envelope,
    )


def _progress(sc, quiet: bool):
    if quiet:
        return None
    from tqdm import tqdm

    return tqdm(total=sc.duration_s, desc=sc.name, unit="sim s", leave=False, file=sys.stderr, bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} sim s [{elapsed}<{remaining}]")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
