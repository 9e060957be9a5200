"""The ``geofence-testbed`` command line.

Subcommands:

* ``run SCENARIO.yaml... --out DIR``: fly scenarios, write trajectory.csv + summary.json each.
* ``batch PATH... --out DIR [--jobs N]``: fly every scenario (and sweep) found, in parallel,
  resumably; write results.csv and report.md.
* ``plot DIR`` / ``compare DIR``: regenerate figures / the platform comparison from saved results.
* ``seed-reproduction DIR``: fly the seed work's indoor quad with the reactive and our predictive fence.
* ``score-log LOG --fence FILE``: score a real flight log (tlog / DataFlash .bin / PX4 .ulg) against a fence file.
* ``import-fence FILE``: turn a GeoJSON / QGC .plan / WPL 110 / MAVProxy fence file into a scenario ``geofence:`` block.
* ``export-fence IN --to FORMAT --out FILE``: write a scenario's or a file's fence as .plan / WPL 110 / MAVProxy /
  GeoJSON / KML.
* ``export-flight RUN_DIR --to geojson|kml --out FILE``: a flown flight's track (coloured by geofence mode), its
  transitions, peak excursion and fence for QGIS / Google Earth.
* ``validate SCENARIO.yaml...``: check scenario files without flying them.
* ``list``: the aircraft that can fly and the shipped example scenarios.
* ``check SCENARIO.yaml...``: the pre-flight mission check (where would the geofence override the mission?).
* ``validate-models``: fly every platform through standard manoeuvres, write docs/validation.md.
* ``characterize --from-params FILE --kind KIND --out PROFILE.yaml``: a profile from autopilot parameters.
* ``campaign generate DIR`` / ``campaign report RESULTS --campaign DIR``: the adversarial efficacy campaign.
* ``companion --connect URL (--scenario FILE | --fence FILE --profile NAME) [--gcs URL]``: the geofence unit as a
  MAVLink companion computer (its own estimator, RC_CHANNELS_OVERRIDE / MANUAL_CONTROL, the fence over the mission
  protocol); with ``--gcs`` between a ground station and the vehicle, taking the fence uploads addressed to it.

Bad input (a missing or malformed file, an unknown aircraft, a value out of
range, a scenario that cannot make sense, two flights of the same name, an
output folder that cannot be written) prints one line
``error: <file>: <field>: <problem>`` on stderr and exits with code 2, never a
traceback, and before anything is flown.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from analysis.formats.replace import replace_text
from scenarios.app import characterize, estimate, falsify

EXIT_BAD_INPUT = 2
EXIT_FLIGHT_FAILED = 1
EXIT_INTERRUPTED = 130

SHIPPED_SCENARIOS = Path(__file__).parents[1]


def _user_errors() -> tuple[type[BaseException], ...]:
    """Bad user input: every parser's error type subclasses :class:`geofence.validation.ConfigError`."""
    from geofence.validation import ConfigError

    return (ConfigError,)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="geofence-testbed",
        description=(
            "Fly small-UAS geofencing scenarios on JSBSim (multicopter and fixed-wing), "
            "under wind, turbulence and gusts, and write trajectories and summaries."
        ),
        epilog="Example: geofence-testbed run scenarios/multicopter_survey_calm.yaml --out out/",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser(
        "run",
        help="fly one or more scenario files",
        description=(
            "Fly each SCENARIO.yaml in closed loop and write DIR/<scenario-name>/trajectory.csv "
            "(one row per control step: time s, lat/lon deg, alt m, ENU position m, ground velocity m/s, "
            "attitude deg, pilot and commanded sticks, geofence mode) and DIR/<scenario-name>/summary.json "
            "(completed, mission_progress, incomplete_reason, scenario_hash, ...). The folder is replaced as a "
            "whole. Two files with the same scenario name are refused. Exit code 0 if every flight "
            "completed, 1 if one did not, 2 on bad input (checked before flying, output folder included)."
        ),
    )
    run.add_argument("scenarios", nargs="+", type=Path, metavar="SCENARIO.yaml", help="scenario file(s) to fly")
    run.add_argument("--out", type=Path, default=Path("out"), metavar="DIR", help="output folder (default: ./out)")
    run.add_argument("--quiet", action="store_true", help="no progress display, only the final lines")
    run.add_argument("--no-plot", action="store_true", help="skip flight.png/flight.svg (ground track, altitude, speed)")
    _mavlink_run_options(run)

    batch = sub.add_parser(
        "batch",
        help="fly every scenario found, in parallel, resumably",
        description=(
            "Fly every scenario YAML found under PATH (files or folders, searched recursively), expanding "
            "sweeps (grids and Monte Carlo draws), in parallel processes. Each finished flight is written "
            "atomically to DIR/<flight>/; re-running the same command skips finished flights whose scenario is "
            "unchanged (same scenario_hash: the scenario, the version and the code) and re-flies edited ones, or all after a "
            "code change, so an interrupted batch resumes and no result is stale. A flight that fails is recorded with its error and the batch goes "
            "on. At the end DIR/results.csv (one row per flight) and DIR/report.md (comparison table, "
            "figures) are written. Exit code 0 if every flight completed, 1 otherwise, 130 if interrupted."
        ),
    )
    batch.add_argument("paths", nargs="+", type=Path, metavar="PATH", help="scenario files or folders")
    batch.add_argument("--out", type=Path, default=Path("out"), metavar="DIR", help="output folder (default: ./out)")
    batch.add_argument("--jobs", type=int, default=None, metavar="N", help="parallel processes (default: all cores)")
    batch.add_argument(
        "--executor", choices=["process", "dask"], default="process", help="local processes (default) or a Dask cluster"
    )
    batch.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler address, with --executor dask")
    batch.add_argument("--quiet", action="store_true", help="no progress bar")
    batch.add_argument("--no-report", action="store_true", help="skip report.md and its figures (results.csv is still written)")
    batch.add_argument("--no-flight-plots", action="store_true", help="skip each flight's flight.png/.svg (faster)")
    batch.add_argument(
        "--trajectories", choices=["all", "notable"], default="all",
        help="whose trajectory.csv to write: all (default), or notable: only flights without a geofence, failed or "
        "incomplete, outside the fence, in a keep-out, landed outside a gap, terminated, or touching down harder "
        "than 1 m/s down or 0.5 m/s across (a campaign's other flights keep their scores in summary.json; about "
        "0.5 MB and a tenth of the wall time a flight saved)",
    )  # fmt: skip

    plot = sub.add_parser(
        "plot",
        help="regenerate figures from saved results",
        description="Regenerate each flight's flight.png/.svg and the batch figures in DIR from the saved trajectories and summaries, without re-flying.",
    )
    plot.add_argument("out", type=Path, metavar="DIR", help="a run or batch output folder")

    compare = sub.add_parser(
        "compare",
        help="platform comparison from saved results",
        description="Print the platform comparison table (per platform and wind level: breaches, peak excursion, activations, recovery time) of the flights in DIR and write DIR/platform_comparison.png/.svg.",
    )
    compare.add_argument("out", type=Path, metavar="DIR", help="a batch output folder")

    seed = sub.add_parser(
        "seed-reproduction",
        help="reproduce the seed flight tests (indoor quad, reactive vs predictive fence)",
        description=(
            "Fly scenarios/paper/indoor_quad.yaml (reactive fence, published PD law) and "
            "indoor_quad_predictive.yaml (our predictive fence) on the same breach attempts; write DIR/seed_reproduction.md "
            "with per-axis overshoot statistics (mean, sd, correlation with the velocity at activation) and the figures."
        ),
    )
    seed.add_argument("out", type=Path, metavar="DIR", help="output folder")
    seed.add_argument("--no-fly", action="store_true", help="re-analyse flights already in DIR")

    score = sub.add_parser(
        "score-log",
        help="score a real flight log against a fence file",
        description=(
            "Read a MAVLink telemetry log (.tlog), an ArduPilot DataFlash log (.bin) or a PX4 ULog (.ulg) and a fence file "
            "(QGroundControl .plan, QGC WPL 110 fence items, MAVProxy fence text, GeoJSON airspace), and print the breach "
            "scores: peak excursion beyond the fence (m), time outside (s), minimum margin (m). Only GeoJSON files can "
            "carry a ceiling, so give one with --ceiling (m above home). The log is checked first: a log with too many "
            "CRC failures, time faults or position glitches, or far from the fence, is refused (exit 2); "
            "otherwise it is scored over its clean part, with a warning on stderr saying what was dropped."
        ),
    )
    score.add_argument("log", type=Path, metavar="LOG", help=".tlog, .bin or .ulg flight log")
    score.add_argument("--fence", type=Path, required=True, metavar="FILE", help="fence file (.plan, WPL 110, MAVProxy, GeoJSON)")
    score.add_argument(
        "--ceiling", type=float, default=None, metavar="M", help="ceiling, m above home (default: the file's, else 120)"
    )
    score.add_argument("--json", action="store_true", help="print only the scores, as one JSON object (warnings on stderr)")
    score.add_argument(
        "--max-fence-distance-km",
        type=float,
        default=50.0,
        metavar="KM",
        help="refuse a log whose median position is farther than this from the fence (default 50; at most 100: "
        "the scores are taken in one flat ENU tangent-plane frame, which at 100 km shortens lengths by 4 m and "
        "stands 0.8 km above the ground)",
    )
    _inclusion_option(score)

    imp = sub.add_parser(
        "import-fence",
        help="convert a fence file into a scenario geofence block",
        description=(
            "Read a fence file and print (or write with -o) the equivalent scenario 'geofence:' YAML block, with any "
            "warnings on stderr. Formats (told apart by content): QGroundControl .plan, QGC WPL 110, MAVProxy fence/rally "
            "text, and RFC 7946 GeoJSON airspace ([lon, lat]; Polygon/MultiPolygon features with properties.geofence "
            "keep_in/keep_out, or the ED-269 properties.restriction, where PROHIBITED/REQ_AUTHORISATION/CONDITIONAL are "
            "keep-outs; holes of the keep-in become keep-outs; a Point with geofence return_point; optional ceiling_m/floor_m "
            "properties). A scenario can also reference the file directly: geofence: {fence: {file: PATH}}."
        ),
    )
    imp.add_argument("fence_file", type=Path, metavar="FILE")
    imp.add_argument(
        "--ceiling",
        type=float,
        default=None,
        metavar="M",
        help="ceiling, m above home (wins over the file's; default: the file's, else 120)",
    )
    imp.add_argument(
        "-o",
        "--output",
        type=Path,
        default=None,
        metavar="OUT.yaml",
        help="write here instead of stdout (coordinates rounded to 1e-7 deg)",
    )
    imp.add_argument("--force", action="store_true", help="overwrite OUT.yaml if it exists")
    _inclusion_option(imp)

    _export_fence_parser(sub)
    _export_flight_parser(sub)

    val = sub.add_parser(
        "validate",
        help="check scenario files without flying",
        description=(
            "Load and validate scenario files, sweeps included (every expanded flight is checked); print one line per "
            "file: 'ok: ...' on stdout, or 'error: ...' on stderr. Every file is checked; exit code 2 if any failed."
        ),
    )
    val.add_argument("scenarios", nargs="+", type=Path, metavar="SCENARIO.yaml")

    chk = sub.add_parser(
        "check",
        help="pre-flight check: will the geofence override this mission?",
        description=(
            "Fly each mission on paper through the geofence unit's own activation margin (planned speed, the "
            "geofence block's forecast wind_prior with its turbulence and gust allowance, the unit's nominal k-sigma "
            "GNSS margins) and list every leg, fixed-wing turn and loiter where the margin falls to 2 m or below: "
            "there the unit would override the mission. A mission that passes is not overridden in flight. "
            "Exit code 0 if every mission passes, 1 if one would be overridden, 2 on bad input."
        ),
    )
    chk.add_argument(
        "scenarios", nargs="+", type=Path, metavar="SCENARIO.yaml", help="scenario file(s) with a mission and a geofence"
    )

    vm = sub.add_parser(
        "validate-models",
        help="fly every platform through standard manoeuvres; write validation.md (or --out FILE)",
        description=(
            "Fly each platform (default: the six hand-built profiles; name characterized ones, e.g. pa28) through standard manoeuvres (full-tilt or "
            "full-throttle step, stop from top speed, zero-tilt wind pick-up, max-bank turn, climb, roll step, "
            "best glide), compare with published figures and write a markdown table per platform to --out "
            "(default: validation.md in the current folder; the checkout's docs/validation.md only when you name it). "
            "The output is checked for writability before anything flies. With "
            "--check-profiles, exit 1 if a profile's envelope differs from what was measured."
        ),
    )
    vm.add_argument("--models", nargs="+", default=None, metavar="MODEL", help="models to fly (default: every profile)")
    vm.add_argument(
        "--out", type=Path, default=Path("validation.md"), metavar="FILE", help="markdown output (default ./validation.md)"
    )
    vm.add_argument("--check-profiles", action="store_true", help="exit 1 when a profile's envelope is not what was measured")
    vm.add_argument(
        "--allow-conservative", action="store_true", help="with --check-profiles: a figure off on the safe side only warns"
    )

    camp = sub.add_parser(
        "campaign",
        help="generate an adversarial efficacy campaign, or report on a flown one",
        description=(
            "generate: write N adversarial cases (fence shapes: box, L, U, star, acute corner, corridor, circle, "
            "keep-outs and buildings, ceilings, floors with gaps; every shipped platform; sites worldwide up to 2,800 m; "
            "winds, turbulence, gusts, GPS faults; head-on, shallow, corner, turning, repeated and breach-attempts "
            "pilots, and normal missions), each "
            "three times (predictive, reactive, unprotected), plus campaign.json, into DIR; fly them with "
            "'geofence-testbed batch DIR --out RESULTS'. report: breaches with 95 % upper confidence bounds per "
            "flight and per flight hour, peak excursions, nuisance overrides, written to RESULTS/campaign_report.md, and one row per flight (condition, status, breaches, whether its unprotected twin breached) in RESULTS/campaign_flights.csv. combine: the containment counts of a campaign's shards (--first-case) added up."
        ),
    )
    camp_sub = camp.add_subparsers(dest="campaign_command", required=True, metavar="ACTION")
    gen = camp_sub.add_parser(
        "generate",
        help="write the campaign's scenario files",
        description="Write N cases x 3 variants of scenario YAML and campaign.json into DIR (reproducible from --seed).",
    )
    gen.add_argument("out", type=Path, metavar="DIR", help="folder for the scenario files (must be new or empty)")
    gen.add_argument("--cases", type=int, default=1000, metavar="N", help="number of cases (default 1000; each is flown 3 times)")
    gen.add_argument("--seed", type=int, default=2026, help="campaign seed, >= 0 (default 2026)")
    gen.add_argument(
        "--first-case", type=int, default=0, metavar="K",
        help="number the cases from K (default 0): a shard of a larger campaign, cases K to K+N-1 of the same --seed "
        "(case i is the same in every shard; 'campaign combine' adds the shards' reports up)",
    )  # fmt: skip
    gen.add_argument("--max-duration-s", type=float, default=180.0, metavar="S", help="longest flight, s (default 180)")
    gen.add_argument(
        "--platforms",
        default=None,
        metavar="A,B",
        help="comma-separated platform profiles to draw from (default: the six hand-measured ones, F450,F450RD,J3Cub,Micro250,Tern,c172x)",
    )
    gen.add_argument(
        "--families",
        default=None,
        metavar="A,B",
        help="comma-separated case families to take turns (default: all but city and random; city: airspace-scale"
        " fences, thousands of vertices and hundreds of buildings, slower to fly; random: random polygons of 5-40"
        " vertices, often with keep-outs in the way back)",
    )
    gen.add_argument(
        "--faults",
        action="store_true",
        help="every case carries one single failure (GNSS loss/degradation/walk-off, baro drift, pitot, compass, "
        "the flight controller ignoring or freezing the override, fixed-wing propulsion loss) in the override, "
        "at the approach or in the recovery, instead of the GPS faults some cases draw; the same cases otherwise",
    )
    gen.add_argument(
        "--downward-sensors",
        action="store_true",
        help="every multirotor's geofence unit carries a downward rangefinder and an optical-flow sensor (the "
        "defaults of the scenario format's sensors: block): the unit flares every touchdown on the measured height "
        "and, with GNSS lost, holds and lands on the flow's velocity; the same cases otherwise",
    )
    rep = camp_sub.add_parser(
        "report",
        help="write campaign_report.md from a flown campaign",
        description="Read RESULTS/results.csv (from batch) and the campaign's campaign.json; write RESULTS/campaign_report.md, its figures, RESULTS/campaign_flights.csv (one row per flight) and RESULTS/containment_counts.json (the containment section's counts, for 'campaign combine').",
    )
    rep.add_argument("results", type=Path, metavar="RESULTS", help="the batch output folder")
    rep.add_argument(
        "--campaign",
        type=Path,
        required=True,
        metavar="DIR",
        help="the folder written by 'campaign generate' (holds campaign.json)",
    )
    comb = camp_sub.add_parser(
        "combine",
        help="add up the containment counts of a campaign's shards",
        description=(
            "Read RESULTS/containment_counts.json of each shard of one campaign (generated with the same --seed and "
            "settings, disjoint --first-case ranges, each flown and reported: 'campaign report'), check they are "
            "of one campaign, not overlapping and not stale, and write the whole campaign's containment table: "
            "exits of the fence, the contingency volume and the ground risk buffer per class, per flight and per "
            "flight hour with their exact 95 % bounds (docs/campaigns.md, 'A SORA-scale run')."
        ),
    )  # fmt: skip
    comb.add_argument("results", type=Path, nargs="+", metavar="RESULTS", help="the shards' results folders")
    comb.add_argument(
        "--out", type=Path, default=Path("containment_combined.md"), metavar="FILE",
        help="the combined report (markdown; default ./containment_combined.md)",
    )  # fmt: skip

    _companion_parser(sub)

    sub.add_parser(
        "list",
        help="list flyable aircraft and shipped scenarios",
        description="List aircraft that have a platform profile, and the example scenarios shipped with the testbed.",
    )
    characterize.register(sub)
    falsify.register(sub)
    estimate.register(sub)
    return parser


def _companion_parser(sub: Any) -> None:
    """The ``companion`` sub-command: the geofence unit as its own process on a MAVLink 2 link."""
    comp = sub.add_parser(
        "companion",
        help="run the geofence unit as a MAVLink companion computer",
        description="The geofence unit as its own process: reads the vehicle's telemetry into its own estimator, "
        "overrides with RC_CHANNELS_OVERRIDE (ArduPilot) or MANUAL_CONTROL (PX4), hands back and releases, serves "
        "its fence over the mission protocol, and measures the link. With --gcs it sits between a ground station "
        "and the vehicle: every message is relayed both ways, except fence and rally-point transfers the ground "
        "station addresses to the vehicle, which the companion answers as the vehicle (validated whole, replacing "
        "its own fence, not forwarded); waypoint missions pass untouched. Exits 0 when the vehicle powers off, after "
        "--max-duration-s, or on Ctrl-C / SIGTERM.",
    )
    comp.add_argument(
        "--connect", required=True, metavar="URL", help="udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT or a serial device"
    )
    comp.add_argument(
        "--gcs",
        metavar="URL",
        help="relay mode: the ground station's link (udpout:HOST:PORT to a GCS listening, udpin:HOST:PORT for one "
        "that connects, tcp or serial); it keeps seeing and commanding the vehicle through the companion",
    )
    comp.add_argument(
        "--scenario", type=Path, metavar="FILE", help="take the fence, profile, sensors and geofence settings from a scenario"
    )
    comp.add_argument("--fence", metavar="FILE", help="a fence file (.plan, WPL 110, MAVProxy, GeoJSON), with --profile")
    comp.add_argument("--profile", metavar="NAME|FILE", help="the platform profile: a shipped model name or a profile YAML")
    comp.add_argument(
        "--ceiling-m", type=float, metavar="M", help="the fence ceiling with --fence (default: the file's, else 120 m AGL)"
    )
    comp.add_argument("--autopilot", choices=("ardupilot", "px4"), help="default: from the vehicle's HEARTBEAT")
    comp.add_argument("--max-duration-s", type=float, metavar="S", help="stop after this long (wall time)")
    comp.add_argument(
        "--source-system",
        type=int,
        default=255,
        metavar="ID",
        help="our MAVLink system id (ArduPilot's SYSID_MYGCS; default 255)",
    )
    comp.add_argument(
        "--target-system", type=int, metavar="ID", help="the vehicle's system id (default: the first vehicle heard)"
    )
    comp.add_argument("--report", type=Path, metavar="FILE.json", help="write the link and override report here")


def _export_fence_parser(sub) -> None:
    ex = sub.add_parser(
        "export-fence",
        help="write a fence as a ground-station file (.plan, WPL 110, MAVProxy, GeoJSON, KML)",
        description=(
            "Read a fence (a scenario file's geofence.fence, or any fence file import-fence reads) and write it as "
            "FORMAT: qgc_plan (QGroundControl .plan: polygons and circles, the breach return point, rally points), "
            "qgc_wpl_110 (mission items 5000-5004 and rally 5100), mavproxy_fence (old FENCE_POINT text: the return "
            "point and the keep-in polygon only), geojson (RFC 7946, properties.geofence roles, ceiling_m/floor_m; "
            "circles as polygons) or kml (Google Earth: extruded polygons up to the ceiling). Coordinates keep every "
            "digit: import-fence reads the same vertices back. What the format cannot carry (the ceiling in the "
            "MAVLink formats, keep-outs in MAVProxy text, circles in GeoJSON/KML) is said on stderr."
        ),
    )
    ex.add_argument("fence_in", type=Path, metavar="IN", help="SCENARIO.yaml or a fence file")
    ex.add_argument("--to", required=True, choices=("qgc_plan", "qgc_wpl_110", "mavproxy_fence", "geojson", "kml"), metavar="FORMAT",
                    help="qgc_plan, qgc_wpl_110, mavproxy_fence, geojson or kml")  # fmt: skip
    ex.add_argument("--out", type=Path, required=True, metavar="FILE", help="the file to write (replaced)")
    ex.add_argument("--ceiling", type=float, default=None, metavar="M", help="with a fence file IN: its ceiling, m above home")
    _inclusion_option(ex)


def _cmd_export_fence(args) -> int:
    from analysis.formats.fence_files import ImportOptions, export_fence, load_fence_file
    from geofence.validation import ConfigError

    check_output_file(args.out, "--out")
    rally: tuple = ()
    if args.fence_in.suffix.lower() in (".yaml", ".yml"):
        from scenarios.definition.schema import load_scenario

        sc = load_scenario(args.fence_in)
        if sc.geofence is None:
            raise ConfigError(f"{args.fence_in}: geofence: the scenario has no fence to export")
        fence = sc.geofence.fence
    else:
        imported = load_fence_file(args.fence_in, ImportOptions(ceiling_m=args.ceiling, inclusion_polygon=args.inclusion_polygon))
        fence, rally = imported.fence, imported.rally_points
        for w in imported.warnings:
            print(f"warning: {args.fence_in}: {w}", file=sys.stderr)
    exported = export_fence(fence, args.to, rally)
    for w in exported.warnings:
        print(f"warning: {w}", file=sys.stderr)
    replace_text(args.out, exported.text)
    print(f"wrote {args.out}")
    return 0


def _export_flight_parser(sub) -> None:
    ex = sub.add_parser(
        "export-flight",
        help="write a flown flight as GeoJSON (QGIS) or KML (Google Earth)",
        description=(
            "Read a flight folder written by run/batch (trajectory.csv, summary.json, scenario.yaml) and write its "
            "track as 3-D lines (lon, lat, alt_m), one per run of a geofence mode, coloured by mode (GeoJSON "
            "properties.mode and stroke; KML one styled Placemark per segment, altitudeMode absolute), a point per "
            "mode transition and at the peak excursion, and the scenario's fence. The track is thinned by "
            "Ramer-Douglas-Peucker in the local ENU frame (every dropped sample within --tolerance of the kept line; "
            "mode changes, transitions and the peak are kept); the file states the tolerance and the error left."
        ),
    )
    ex.add_argument("run_dir", type=Path, metavar="RUN_DIR", help="a flight folder written by run or batch")
    ex.add_argument("--to", required=True, choices=("geojson", "kml"), metavar="FORMAT", help="geojson or kml")
    ex.add_argument("--out", type=Path, required=True, metavar="FILE", help="the file to write (replaced)")
    ex.add_argument("--tolerance", type=float, default=0.5, metavar="M",
                    help="decimation tolerance, m (3-D; 0 keeps every sample; default 0.5)")  # fmt: skip
    ex.add_argument("--max-points", type=int, default=50_000, metavar="N",
                    help="most track vertices: past them the tolerance is doubled until the track fits (default 50000)")  # fmt: skip
    ex.add_argument("--extrude", action="store_true", help="KML: draw the track as a curtain down to the ground")


def read_flight_folder(folder: Path) -> tuple[dict, dict, Any]:
    """A flight folder's trajectory columns, summary and scenario, or a one-line :class:`ConfigError` naming the
    file and the problem."""
    import json

    from analysis.formats.flight_export import TRACK_COLUMNS
    from geofence.validation import ConfigError
    from scenarios.definition.schema import parse_scenario, read_document
    from scenarios.flight.recorder import read_trajectory_csv

    if not folder.is_dir():
        raise ConfigError(f"{folder}: not a flight folder (not a folder): give one written by run or batch")
    for file in ("trajectory.csv", "summary.json", "scenario.yaml"):
        if not (folder / file).is_file():
            raise ConfigError(f"{folder}: not a flight folder (no {file}): give one written by run or batch")
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (ValueError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{folder / 'summary.json'}: not JSON ({' '.join(str(exc).split())[:80]})") from None
    if not isinstance(summary, dict):
        raise ConfigError(f"{folder / 'summary.json'}: not a flight summary (not a JSON object)")
    sc = parse_scenario(read_document(folder / "scenario.yaml"), str(folder / "scenario.yaml"), folder.name)
    traj = read_trajectory_csv(folder / "trajectory.csv", TRACK_COLUMNS)
    return traj, summary, sc


def _cmd_export_flight(args) -> int:
    from analysis.formats.flight_export import export_flight, transitions_from_summary

    check_output_file(args.out, "--out")
    traj, summary, sc = read_flight_folder(args.run_dir)
    exported = export_flight(
        traj, args.to, name=str(args.run_dir / "trajectory.csv"), title=sc.name,
        transitions=transitions_from_summary(summary.get("mode_transitions"), str(args.run_dir / "summary.json")),
        fence=sc.geofence.fence if sc.geofence is not None else None, local_fence=sc.local_fence(),
        ground_alt_m=sc.start.ground_alt_m, tolerance_m=args.tolerance, max_points=args.max_points, extrude=args.extrude,
    )  # fmt: skip
    for w in exported.warnings:
        print(f"warning: {w}", file=sys.stderr)
    replace_text(args.out, exported.text)
    d = exported.decimated
    print(f"wrote {args.out}: {len(exported.segments)} segments, {len(d.indices)} of {len(traj['time_s'])} samples "
          f"(within {exported.tolerance_m:g} m; largest deviation {d.max_error_m:.3f} m)")  # fmt: skip
    return 0


def _mavlink_run_options(run: argparse.ArgumentParser) -> None:
    """``run``'s MAVLink flags: the flight as a MAVLink vehicle, and its telemetry log."""
    g = run.add_argument_group(
        "MAVLink vehicle",
        "With --mavlink the flight has no in-process geofence unit: it publishes its telemetry (system 1, "
        "component 1; ATTITUDE and GLOBAL_POSITION_INT at 50 Hz capped at the control rate, GPS_RAW_INT per fix, "
        "SCALED_PRESSURE and VFR_HUD 10 Hz, WIND 2 Hz, HEARTBEAT 1 Hz) and flies the sticks a companion commands "
        "(RC_CHANNELS_OVERRIDE from system 255, or MANUAL_CONTROL with --mavlink-autopilot px4) in place of the "
        "pilot's. summary.json is still scored against the scenario's fence and gains a 'link' block.",
    )
    g.add_argument("--mavlink", metavar="URL", help="pymavlink URL to speak on, e.g. udpout:127.0.0.1:14550")
    g.add_argument(
        "--mavlink-autopilot", choices=("ardupilot", "px4"), default="ardupilot",
        help="whose HEARTBEAT and override conventions (default ardupilot)",
    )  # fmt: skip
    g.add_argument(
        "--lockstep", action="store_true",
        help="start when the companion's HEARTBEAT comes back, then after each tick's ATTITUDE wait for its "
        "NAMED_VALUE_FLOAT GF_MARGIN of that tick (deterministic; default: paced to wall-clock time, never waiting)",
    )  # fmt: skip
    g.add_argument(
        "--lockstep-timeout-s", type=float, default=10.0, metavar="S", help="lock-step wait bound per tick, wall s (default 10)"
    )
    g.add_argument(
        "--lockstep-start-timeout-s", type=float, default=120.0, metavar="S",
        help="how long to wait for the companion's first HEARTBEAT, wall s (default 120: a companion on a cold "
        "cache compiles for about a minute before it listens)",
    )  # fmt: skip
    g.add_argument(
        "--rc-override-time-s", type=float, default=3.0, metavar="S",
        help="ArduPilot RC_OVERRIDE_TIME: an override channel reverts to the pilot this long after its last "
        "override (default 3; -1 never)",
    )  # fmt: skip
    g.add_argument(
        "--tlog", type=Path, metavar="FILE",
        help="also write the flight as a MAVLink 2 telemetry log (one scenario only): with --mavlink every message "
        "sent and received, else the recorded trajectory as the vehicle's telemetry",
    )  # fmt: skip


def _check_mavlink_run_options(args) -> None:
    from geofence.validation import ConfigError

    if args.tlog is not None:
        if len(args.scenarios) != 1:
            raise ConfigError("--tlog: give exactly one scenario")
        check_output_file(args.tlog, "--tlog")
    if args.mavlink is None and args.lockstep:
        raise ConfigError("--lockstep: needs --mavlink URL")
    if not args.lockstep_timeout_s > 0.0:
        raise ConfigError(f"--lockstep-timeout-s: must be > 0, got {args.lockstep_timeout_s:g}")
    if not args.lockstep_start_timeout_s > 0.0:
        raise ConfigError(f"--lockstep-start-timeout-s: must be > 0, got {args.lockstep_start_timeout_s:g}")


def _fly_and_write(sc, spec, args, on_step):
    """Fly one scenario of ``run`` (in process, or as a MAVLink vehicle) and write its folder and tlog."""
    from scenarios.flight.runner import run_scenario, write_result

    if args.mavlink is None:
        result = run_scenario(sc, args.out, on_step=on_step, plot=not args.no_plot, scenario_hash=spec.scenario_hash)
        if args.tlog is not None:
            from geofence.interface import PlatformKind
            from scenarios.link.sticks import Autopilot
            from scenarios.link.tlog import write_trajectory_tlog

            traj = {name: result.recorder.column(name) for name in result.recorder.columns}
            kind = PlatformKind(result.summary["platform_kind"])
            write_trajectory_tlog(traj, args.tlog, kind, autopilot=Autopilot(args.mavlink_autopilot))
        return result
    from scenarios.flight.mavlink_vehicle import LinkOptions, fly_mavlink
    from scenarios.link.sticks import Autopilot

    opts = LinkOptions(
        url=args.mavlink, autopilot=Autopilot(args.mavlink_autopilot), lockstep=args.lockstep,
        lockstep_timeout_s=args.lockstep_timeout_s, lockstep_start_timeout_s=args.lockstep_start_timeout_s,
        rc_override_time_s=args.rc_override_time_s, tlog=args.tlog,
    )  # fmt: skip
    result = fly_mavlink(sc, opts, on_step=on_step)
    text = Path(sc.source).read_text() if sc.source is not None and Path(sc.source).is_file() else None
    write_result(result, args.out, scenario_text=text, plot=not args.no_plot, scenario_hash=spec.scenario_hash)
    if result.summary.get("error"):
        print(f"error: {sc.name}: {result.summary['error']}", file=sys.stderr)
    return result


def _inclusion_option(sub: argparse.ArgumentParser) -> None:
    sub.add_argument(
        "--inclusion-polygon",
        type=int,
        default=None,
        metavar="N",
        help="the inclusion area to use as the keep-in, by index (0-based: polygons in file order, then circles). "
        "Required when the file has several: ArduPilot flies several inclusion zones as their intersection "
        "(their union with FENCE_OPTIONS bit 1), a fence here holds one keep-in, so such a file is refused "
        "unless you pick one",
    )


OWN_PACKAGES: dict[str, str] = {
    "aircraft": "aircraft.jsbsim_model",
    "analysis": "analysis.scoring",
    "geofence": "geofence.unit.geofence_unit",
    "scenarios": "scenarios.app.cli",
    "wind": "wind.dryden",
}
"""Our five top-level packages, each with one module only ours has (see the README on namespacing)."""


def shadowed_packages() -> list[str]:
    """One line per top-level name that is not this distribution's (another installed package shadows it)."""
    import importlib
    import importlib.util

    home = Path(__file__).resolve().parents[2]
    problems = []
    for name, marker in OWN_PACKAGES.items():
        try:
            pkg = importlib.import_module(name)
            found = importlib.util.find_spec(marker) is not None
        except ImportError:
            pkg, found = None, False
        where = Path(getattr(pkg, "__file__", None) or "?").resolve()
        if not found or where.parents[1] != home:
            problems.append(
                f"the package {name!r} imported from {where} is not geofence-testbed's (expected under {home}): "
                f"another installed package shadows it; use a virtual environment (see README)"
            )
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    for line in shadowed_packages():
        print(f"geofence-testbed: {line}", file=sys.stderr)
        return 2
    if args.command in ("run", "batch", "seed-reproduction"):
        _sigterm_interrupts()
    try:
        if getattr(args, "handler", None) is not None:  # a subcommand that registers its own handler
            return args.handler(args)
        if args.command == "run":
            return _cmd_run(args)
        if args.command == "batch":
            return _cmd_batch(args)
        if args.command == "plot":
            return _cmd_plot(args)
        if args.command == "compare":
            return _cmd_compare(args)
        if args.command == "seed-reproduction":
            from scenarios.app.seed_reproduction import run as seed_run

            check_output_dir(args.out, "DIR")
            print(f"wrote {seed_run(args.out, fly_flights=not args.no_fly)}")
            return 0
        if args.command == "score-log":
            return _cmd_score_log(args)
        if args.command == "import-fence":
            return _cmd_import_fence(args)
        if args.command == "export-fence":
            return _cmd_export_fence(args)
        if args.command == "export-flight":
            return _cmd_export_flight(args)
        if args.command == "validate":
            return _cmd_validate(args)
        if args.command == "list":
            return _cmd_list()
        if args.command == "check":
            return _cmd_check(args)
        if args.command == "validate-models":
            from aircraft.profile import load_profile
            from aircraft.validation import run_validation

            for model in args.models or []:
                load_profile(model)  # an unknown model is one line, exit 2, before anything flies
            check_output_file(args.out, "--out")
            return run_validation(
                args.models, args.out, check_profiles=args.check_profiles, allow_conservative=args.allow_conservative
            )
        if args.command == "campaign":
            return _cmd_campaign(args)
        if args.command == "companion":
            from scenarios.app.companion import run_companion

            return run_companion(args)
    except _user_errors() as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:  # a file system refusal we could not foresee (disk full, a folder removed meanwhile)
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("interrupted: finished results are kept", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_BAD_INPUT  # pragma: no cover - argparse guarantees a command


def _cmd_check(args) -> int:
    """The pre-flight mission check of each scenario (exit 1 if any mission would be overridden)."""
    from scenarios.definition.preflight import describe_findings, preflight_findings
    from scenarios.definition.schema import load_scenario

    scenarios = [load_scenario(p) for p in args.scenarios]  # every file validated before anything is checked
    overridden = 0
    for path, sc in zip(args.scenarios, scenarios):
        findings = preflight_findings(sc)
        overridden += bool(findings)
        print(f"{path}: {describe_findings(findings)}")
    return EXIT_FLIGHT_FAILED if overridden else 0


def _cmd_campaign(args) -> int:
    if args.campaign_command == "combine":
        from analysis.campaign_report import combine_containment

        check_output_file(args.out, "--out")
        print(f"wrote {combine_containment(args.results, args.out)}")
        return 0
    if args.campaign_command == "generate":
        from scenarios.campaign.generator import generate_campaign

        if args.cases < 1:
            print(f"error: --cases: must be >= 1, got {args.cases}", file=sys.stderr)
            return EXIT_BAD_INPUT
        if not 0 <= args.seed < 2**63:
            print(f"error: --seed: must be an integer in [0, 2^63), got {args.seed}", file=sys.stderr)
            return EXIT_BAD_INPUT
        if args.first_case < 0:
            print(f"error: --first-case: must be >= 0, got {args.first_case}", file=sys.stderr)
            return EXIT_BAD_INPUT
        if args.out.exists() and (not args.out.is_dir() or any(args.out.iterdir())):
            print(f"error: {args.out}: must be a new or empty folder (a campaign is never written over another)", file=sys.stderr)
            return EXIT_BAD_INPUT
        platforms = None
        if args.platforms is not None:
            from aircraft.profile import available_profiles

            platforms = [p.strip() for p in args.platforms.split(",") if p.strip()]
            unknown = [p for p in platforms if p not in available_profiles()]
            if not platforms or unknown:
                print(
                    f"error: --platforms: unknown profile {unknown[0] if unknown else '(none given)'!r} "
                    f"(shipped: {', '.join(available_profiles())})",
                    file=sys.stderr,
                )
                return EXIT_BAD_INPUT
        families = None
        if args.families is not None:
            from scenarios.campaign.generator import CaseFamily

            names = [f.strip() for f in args.families.split(",") if f.strip()]
            known = {f.value: f for f in CaseFamily}
            unknown = [f for f in names if f not in known]
            if not names or unknown:
                print(
                    f"error: --families: unknown family {unknown[0] if unknown else '(none given)'!r} "
                    f"(known: {', '.join(known)})",
                    file=sys.stderr,
                )
                return EXIT_BAD_INPUT
            families = [known[f] for f in names]
        paths = generate_campaign(
            args.out, args.cases, args.seed, platforms=platforms, families=families,
            max_duration_s=args.max_duration_s, faults=args.faults, downward_sensors=args.downward_sensors,
            first_case=args.first_case,
        )  # fmt: skip
        print(
            f"wrote {len(paths)} scenario files and {args.out / 'campaign.json'}; fly them with: "
            f"geofence-testbed batch {args.out} --out RESULTS"
        )
        return 0
    from analysis.campaign_report import write_campaign_report

    manifest = args.campaign / "campaign.json"
    for path, what in ((args.results / "results.csv", "RESULTS/results.csv (run batch first)"), (manifest, "campaign.json")):
        if not path.is_file():
            print(f"error: {path}: missing ({what})", file=sys.stderr)
            return EXIT_BAD_INPUT
    print(f"wrote {write_campaign_report(args.results, manifest, contingency=_contingency_inputs())}")
    return 0


def _contingency_inputs() -> dict:
    """Each shipped profile's figures for the report's contingency volume (top speed, reaction time, bank/tilt)."""
    from aircraft.profile import available_profiles, load_profile
    from analysis.containment import ContingencyInputs
    from geofence.interface import PlatformKind

    out = {}
    for name in available_profiles():
        env = load_profile(name).envelope
        limit = env.max_bank_rad if env.kind is PlatformKind.FIXED_WING else min(env.max_bank_rad, env.max_pitch_rad)
        out[name] = ContingencyInputs(env.kind, env.max_speed_mps, env.reaction_time_s, limit)
    return out


def _cmd_validate(args) -> int:
    """Every file is checked (sweeps expanded, each flight validated); one line per file; exit 2 if any failed."""
    from scenarios.app.batch import check_unique_names
    from scenarios.definition.schema import parse_scenario, read_document
    from scenarios.definition.sweep import expand

    failed = 0
    for path in args.scenarios:
        try:
            raw = read_document(path)
            specs = expand(raw, str(path), path.stem)
            check_unique_names(specs)
            sweep = isinstance(raw, dict) and "sweep" in raw
            scenarios = [
                parse_scenario(spec.document, f"{path} [{spec.flight_id}]" if sweep else str(path), spec.flight_id, source=path)
                for spec in specs
            ]
        except _user_errors() as exc:
            print(f"error: {exc}", file=sys.stderr)
            failed += 1
            continue
        for w in dict.fromkeys(w for sc in scenarios for w in sc.warnings):
            print(f"warning: {w}", file=sys.stderr)
        for w in dict.fromkeys(w for sc in scenarios if sc.geofence is not None for w in sc.geofence.fence_warnings):
            print(f"warning: {path}: fence file: {w}", file=sys.stderr)
        sc = scenarios[0]
        if sweep:
            aircraft = ", ".join(dict.fromkeys(x.aircraft for x in scenarios))
            print(
                f"ok: {path}: sweep of {len(scenarios)} flights ({aircraft}, {sc.pilot.kind}, up to {max(x.duration_s for x in scenarios):g} s)"
            )
        else:
            print(f"ok: {path}: {sc.name} ({sc.aircraft}, {sc.pilot.kind}, {sc.duration_s:g} s)")
    return EXIT_BAD_INPUT if failed else 0


def _cmd_list() -> int:
    from aircraft.profile import available_profiles, load_profile

    print("aircraft (platform profiles):")
    for model in available_profiles():
        p = load_profile(model)
        note = "  (the drag-free reference: no rotor drag; fly F450RD for a credible drone)" if model == "F450" else ""
        print(f"  {model:10s} {p.kind.value:11s} cruise {p.envelope.cruise_speed_mps:.0f} m/s{note}")
    print("shipped scenarios (ci/ holds sweeps: run them with 'batch'):")
    for path in sorted(SHIPPED_SCENARIOS.rglob("*.yaml")):
        print(f"  {path.relative_to(SHIPPED_SCENARIOS.parent)}")
    return 0


PROGRESS_LABELS = {"mission": "mission", "scripted": "segments", "breach_attempts": "attempts"}
"""What ``mission_progress`` counts, per pilot kind, in the console line."""


def _cmd_run(args) -> int:
    from scenarios.app.batch import check_unique_names
    from scenarios.definition.schema import load_scenario, read_document
    from scenarios.definition.sweep import expand

    scenarios = [load_scenario(p) for p in args.scenarios]  # validate everything before flying anything
    specs = [expand(read_document(p), str(p), p.stem)[0] for p in args.scenarios]
    check_unique_names(specs)
    check_output_dir(args.out, "--out")
    _check_mavlink_run_options(args)
    for w in dict.fromkeys(w for sc in scenarios for w in sc.warnings):
        print(f"warning: {w}", file=sys.stderr)
    failed = 0
    for sc, spec in zip(scenarios, specs):
        bar = _progress(sc, quiet=args.quiet)
        on_step, notice = progress_steps(bar)
        try:
            result = _fly_and_write(sc, spec, args, _stops_when_interrupted(on_step))
        finally:
            if notice is not None:
                notice.cancel()
            if bar:
                bar.close()
        s = result.summary
        status = "completed" if s["completed"] else "NOT completed"
        label = PROGRESS_LABELS.get(str(s.get("pilot")), "progress")
        print(
            f"{sc.name}: {status}, {label} {s['mission_progress']}, {s['sim_time_s']:.1f} s simulated "
            f"in {s['wall_time_s']:.1f} s -> {args.out / sc.name}"
        )
        if not s["completed"]:
            print(f"  why: {s.get('incomplete_reason') or s.get('error') or 'unknown'}")
        failed += not s["completed"]
    return EXIT_FLIGHT_FAILED if failed else 0


def check_output_dir(path: Path, option: str = "--out") -> None:
    """Refuse, before anything is flown, an output folder that is a file or cannot be created or written."""
    from geofence.validation import ConfigError

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ConfigError(f"{option}: {path}: exists and is not a folder")
    probe = path
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent  # the nearest existing ancestor, where the folder would be created
    if not probe.is_dir():
        raise ConfigError(f"{option}: {path}: cannot be created: {probe} is not a folder")
    if not _writable(probe):
        problem = "is not writable" if probe == path else f"cannot be created: {probe} is not writable"
        raise ConfigError(f"{option}: {path}: {problem}")


def check_output_file(path: Path, option: str) -> None:
    """Refuse, before anything is flown, an output file that is a folder or whose folder cannot be written."""
    from geofence.validation import ConfigError

    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{option}: {path}: is a folder; give a file name, e.g. {path / 'validation.md'}")
    if path.exists() and not os.access(path, os.W_OK):
        raise ConfigError(f"{option}: {path}: is not writable")
    check_output_dir(path.parent, option)


def _writable(folder: Path) -> bool:
    """Whether a file can be created in ``folder`` (tried for real: permissions, read-only mounts, root)."""
    try:
        fd, name = tempfile.mkstemp(prefix=".gft-write-test-", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(name)
    return True


_INTERRUPTED: list[bool] = [False]
"""Set by Ctrl-C or SIGTERM: a flight's next step stops it (see :func:`_stops_when_interrupted`)."""


def _sigterm_interrupts() -> None:
    """SIGTERM ends a run like Ctrl-C: finished results are kept, temporary files removed, exit 130. Both also
    set :data:`_INTERRUPTED`: a KeyboardInterrupt raised while numba compiles the kernels is swallowed by its
    ctypes callback (the run went on to its end, exit 0), so the flight's next step raises it again."""

    def handler(signum, frame):
        _INTERRUPTED[0] = True
        raise KeyboardInterrupt

    default_hook = sys.unraisablehook

    def quiet_interrupt(unraisable) -> None:  # the swallowed one: not a traceback on the console
        if unraisable.exc_type is not None and issubclass(unraisable.exc_type, KeyboardInterrupt):
            return
        default_hook(unraisable)

    sys.unraisablehook = quiet_interrupt

    try:
        signal.signal(signal.SIGTERM, handler)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, handler)
    except ValueError:  # pragma: no cover - not the main thread (main() called from a thread)
        pass


def _stops_when_interrupted(on_step: Callable[[float], None] | None) -> Callable[[float], None]:
    """``on_step`` (or nothing) that first raises KeyboardInterrupt if a signal interrupted the run."""

    def step(dt_s: float) -> None:
        if _INTERRUPTED[0]:
            raise KeyboardInterrupt
        if on_step is not None:
            on_step(dt_s)

    return step


def _version() -> str:
    from scenarios.definition.sweep import project_version

    return project_version()


def _cmd_batch(args) -> int:
    from scenarios.app.batch import Trajectories, discover, output_lock, plan, resume_state, run_batch

    if args.jobs is not None and args.jobs < 1:
        from geofence.validation import ConfigError

        raise ConfigError(f"--jobs: must be >= 1, got {args.jobs}")
    if args.scheduler is not None:
        check_scheduler_address(args.scheduler)
    specs = plan(discover(args.paths))  # refuses duplicate names and bad sweeps up front
    check_output_dir(args.out, "--out")
    if args.out.is_dir():
        changed = len(resume_state(specs, args.out).changed)
        if changed:
            print(
                f"re-flying {changed} changed flight{'s' if changed != 1 else ''} (scenario, version or code differs from the stored result)"
            )
    args.out.mkdir(parents=True, exist_ok=True)
    with output_lock(args.out):  # the flights and the batch's reports under one lock (it nests in run_batch)
        outcome = run_batch(
            specs,
            args.out,
            jobs=args.jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            progress=not args.quiet,
            flight_plots=not args.no_flight_plots,
            trajectories=Trajectories(args.trajectories),
        )
        _write_batch_outputs(args.out, report=not args.no_report)
    print(
        f"{outcome.total} flights: {outcome.skipped} already done, {outcome.flown} flown, {len(outcome.failed)} failed "
        f"in {outcome.wall_time_s:.1f} s -> {args.out / 'results.csv'}"
    )
    for flight in outcome.failed:
        why = outcome.reasons.get(flight)
        print(f"  failed: {flight}{f': {why}' if why else ''} (see {args.out / flight / 'summary.json'})")
    if outcome.interrupted:
        print("interrupted: finished flights are kept; run the same command again to resume", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_FLIGHT_FAILED if outcome.failed else 0


def check_scheduler_address(address: str) -> None:
    """A ``--scheduler`` that is not a well-formed address (``http://[::1``, a port out of range) is one line."""
    from urllib.parse import urlsplit

    from geofence.validation import ConfigError

    try:
        parts = urlsplit(address if "://" in address else f"tcp://{address}")
        parts.port  # noqa: B018 - parses the port, raises ValueError when it is malformed
    except ValueError as exc:
        raise ConfigError(f"--scheduler {address}: not a valid address ({exc}); expected tcp://HOST:PORT") from None


def _write_batch_outputs(out_dir: Path, report: bool) -> None:
    from analysis.report import collect_results, write_report, write_results_csv

    rows = collect_results(out_dir)
    write_results_csv(rows, Path(out_dir) / "results.csv")
    if report:
        write_report(out_dir, rows)


def _cmd_plot(args) -> int:
    from analysis.plots import plot_flight, scenario_plot_kwargs
    from geofence.validation import ConfigError
    from scenarios.definition.schema import parse_scenario, read_document

    folders = sorted(p.parent for p in Path(args.out).glob("*/trajectory.csv"))
    if not folders and not (Path(args.out) / "trajectory.csv").is_file():
        raise ConfigError(f"{args.out}: no flights found (no */trajectory.csv)")
    if (Path(args.out) / "trajectory.csv").is_file():
        folders = [Path(args.out)]
    for folder in folders:
        traj = read_trajectory(folder / "trajectory.csv")
        fence = envelope = None
        plot_kwargs: dict = {}
        if (folder / "scenario.yaml").is_file():
            sc = parse_scenario(read_document(folder / "scenario.yaml"), str(folder / "scenario.yaml"), folder.name)

            if sc.geofence is not None:
                fence = sc.local_fence()
            envelope = sc.profile.envelope
            plot_kwargs = scenario_plot_kwargs(sc)  # the unit's trigger, the scenario's wind, its GNSS faults
        plot_flight(traj, folder / "flight", folder.name, fence=fence, envelope=envelope, **plot_kwargs)
        print(f"{folder / 'flight.png'}")
    if len(folders) > 1 or folders[0] != Path(args.out):
        _write_batch_outputs(args.out, report=True)
        print(f"{Path(args.out) / 'report.md'}")
    return 0


PLOT_COLUMNS = ("time_s", "east_m", "north_m", "agl_m", "ground_speed_mps", "airspeed_mps")
"""The trajectory.csv columns a flight figure needs."""


def read_trajectory(path: Path) -> dict:
    """A flight's trajectory.csv with the columns a figure needs, or a one-line :class:`ConfigError`
    (:func:`scenarios.flight.recorder.read_trajectory_csv`)."""
    from scenarios.flight.recorder import read_trajectory_csv

    return read_trajectory_csv(path, PLOT_COLUMNS)


def _cmd_compare(args) -> int:
    from analysis.batch_plots import comparison_table, plot_platform_comparison
    from analysis.report import collect_results
    from geofence.validation import ConfigError

    rows = collect_results(args.out)
    if not rows:
        raise ConfigError(f"{args.out}: no flight results found (no */summary.json)")
    print(comparison_table(rows))
    for path in plot_platform_comparison(rows, Path(args.out) / "platform_comparison"):
        print(path)
    return 0


def _cmd_score_log(args) -> int:
    import json
    import math

    from analysis.formats.fence_files import ImportOptions, load_fence_file, summarize
    from analysis.formats.logs import check_distance_bound, check_near_fence, describe, load_log
    from analysis.scoring import score_flight

    check_distance_bound(args.max_fence_distance_km * 1000.0)
    imported = load_fence_file(args.fence, ImportOptions(ceiling_m=args.ceiling, inclusion_polygon=args.inclusion_polygon))
    traj, info = load_log(args.log)
    check_near_fence(traj, imported.fence, args.max_fence_distance_km * 1000.0, name=str(args.log))
    scores = score_flight(traj, imported.fence.to_local(info.frame))
    warnings = list(dict.fromkeys([*imported.warnings, *info.warnings]))  # each once, in order
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)

    def clean(v):
        return (round(v, 3) if math.isfinite(v) else None) if isinstance(v, float) else v

    out = {k: clean(v) for k, v in scores.items()}
    out["warnings"] = warnings
    if not args.json:  # the summaries; their warning lines are already on stderr
        print(describe(info))
        print("\n".join(line for line in summarize(imported).splitlines() if not line.lstrip().startswith("warning:")))
    print(json.dumps(out, indent=None if args.json else 2))
    return 0


def _cmd_import_fence(args) -> int:
    import yaml

    from analysis.formats.fence_files import ImportOptions, fence_to_yaml_block, load_fence_file
    from geofence.validation import ConfigError

    out = args.output
    if out is not None:
        if out.is_dir():
            raise ConfigError(f"-o: {out}: is a folder; give a file name, e.g. {out / 'fence.yaml'}")
        if out.exists() and not args.force:
            raise ConfigError(f"-o: {out}: exists; add --force to overwrite it")
        check_output_dir(out.parent, "-o")
    imported = load_fence_file(args.fence_file, ImportOptions(ceiling_m=args.ceiling, inclusion_polygon=args.inclusion_polygon))
    for w in imported.warnings:
        print(f"warning: {w}", file=sys.stderr)
    text = yaml.safe_dump(_rounded(fence_to_yaml_block(imported)), sort_keys=False)
    if out is not None:
        replace_text(out, text)
        print(f"wrote {out}")
    else:
        print(text, end="")
    return 0


COORDINATE_DECIMALS = 7
"""import-fence rounds every number to 1e-7 (about 1 cm in latitude): no float noise like 8.543435299999999."""


def _rounded(value):
    if isinstance(value, float):
        return round(value, COORDINATE_DECIMALS)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_rounded(v) for v in value]
    return value


def progress_steps(bar, notice_after_s: float | None = None):
    """``(on_step, notice)`` for a flight's progress ``bar`` (``(None, None)`` without one).

    If the first step has not ended after ``notice_after_s`` (default
    :data:`scenarios.app.batch.SLOW_START_NOTICE_S`; the first flight after an install compiles the
    per-step kernels), ``notice`` (a timer, cancelled by the first step) says so above the bar; the bar's
    clock restarts at the first step, so its time left is the flight's, not the compiler's.
    """
    if bar is None:
        return None, None
    from scenarios.app.batch import SLOW_START_NOTICE_S, slow_start_notice

    notice = slow_start_notice(bar, SLOW_START_NOTICE_S if notice_after_s is None else notice_after_s)
    started = False

    def on_step(dt_s: float) -> None:
        nonlocal started
        if not started:
            started = True
            notice.cancel()
            bar.reset(total=bar.total)  # the clock starts now: time left from the flight's own pace
        bar.update(dt_s)

    return on_step, notice


def _progress(sc, quiet: bool):
    if quiet:
        return None
    from tqdm import tqdm

    return tqdm(
        total=sc.duration_s,
        desc=sc.name,
        unit="sim s",
        leave=False,
        file=sys.stderr,
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} sim s [{elapsed}<{remaining}]",
    )


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
