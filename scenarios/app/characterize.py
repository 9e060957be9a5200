"""The ``characterize`` command: an airframe's profile YAML, flown and measured or from its autopilot parameters.

Owns the subparser and the writing of the profile (header comment per figure: how it was measured, or which
parameter gave it, or which base profile it was taken from). ``characterize MODEL`` flies a fixed-wing JSBSim
model (:mod:`aircraft.characterization`); ``--from-params`` parses a parameter file (:mod:`aircraft.autopilot_params`).
"""

from __future__ import annotations

import datetime
from pathlib import Path

DEFAULT_BASE = {"multirotor": "F450", "fixed_wing": "c172x"}


def register(sub) -> None:
    """Add the ``characterize`` subparser; its handler is ``args.handler``."""
    p = sub.add_parser(
        "characterize",
        help="write an airframe's profile: fly a fixed-wing JSBSim MODEL, or read an ArduPilot/PX4 parameter file",
        description=(
            "characterize MODEL --out P.yaml flies a fixed-wing JSBSim model (the jsbsim wheel's, ours, or one in "
            "--aircraft-dir) with the testbed's fixed-wing controller in the sim and writes a profile measured on it: "
            "the propeller lever of most thrust, the minimum and maximum level speeds (cruise/min/max picked with "
            "margins), the level-flight trim at cruise, the climb and descent rates it flies, controller gains tuned by "
            "a small search scored on roll, climb/descent and throttle steps, a max-bank turn check, then the envelope "
            "measured with validate-models' manoeuvres (decelerations and reaction time declared 10 percent on the safe "
            "side). It prints a line per manoeuvre and takes well under a minute per model. A model it cannot fly is "
            "refused with one line (exit 2): unknown, no engine (glider, ball), a multirotor (fixed-wing only in this "
            "version), more than one engine, no standard aileron/elevator/rudder controls, an engine without thrust, "
            "a failed trim, or a loop no gain set tried could stabilise. "
            "characterize --from-params FILE --kind KIND --out P.yaml instead reads an ArduPilot .param file (NAME VALUE or NAME,VALUE lines) or a PX4 QGroundControl .params export "
            "and writes a profile YAML (the format of aircraft/profiles/*.yaml) whose envelope holds the limits the "
            "parameters set: tilt/bank, pitch, cruise/min/max speed, climb and descent rate (and for PX4 "
            "multicopters horizontal braking and yaw rate). Figures the parameters cannot give, and the flight-"
            "controller gains, come from --base and are marked so in the file's header. Parameters that break the "
            "envelope's rules (e.g. cruise above max speed) are refused with one line (exit 2)."
        ),
    )
    p.add_argument("model", nargs="?", metavar="MODEL", help="a fixed-wing JSBSim model to fly and measure")
    p.add_argument("--aircraft-dir", type=Path, metavar="DIR",
                   help="your own models: a folder holding MODEL/MODEL.xml (like JSBSim's aircraft/), or MODEL's folder")  # fmt: skip
    p.add_argument("--from-params", type=Path, metavar="FILE", help="ArduPilot .param or PX4 .params file")
    p.add_argument("--kind", choices=sorted(DEFAULT_BASE), help="multirotor or fixed_wing (required with --from-params)")
    p.add_argument("--base", metavar="PROFILE",
                   help="shipped profile for the other figures and the gains (default: F450 / c172x by --kind)")  # fmt: skip
    p.add_argument("--out", type=Path, metavar="PROFILE.yaml", help="the profile file to write (replaced)")
    p.set_defaults(handler=run)


def run(args) -> int:
    from aircraft.autopilot_params import read_param_file
    from aircraft.profile import load_profile
    from analysis.formats.replace import replace_text
    from geofence.interface import PlatformKind
    from geofence.validation import ConfigError
    from scenarios.app.cli import check_output_file

    if args.model is not None:
        return run_model(args)
    if args.aircraft_dir is not None:
        raise ConfigError("characterize: --aircraft-dir: only with a MODEL to fly")
    for option, value in (("--from-params", args.from_params), ("--kind", args.kind), ("--out", args.out)):
        if value is None:
            raise ConfigError(f"characterize: {option}: required")
    check_output_file(args.out, "--out")
    kind = PlatformKind(args.kind)
    base_name = args.base or DEFAULT_BASE[args.kind]
    base = load_profile(base_name)
    if base.kind is not kind:
        raise ConfigError(f"--base: {base_name}: is a {base.kind.value} profile, not {kind.value}")
    text = profile_text(read_param_file(args.from_params), kind, base, base_name, str(args.from_params))
    replace_text(args.out, text)
    print(f"wrote {args.out}")
    return 0


def run_model(args) -> int:
    """``characterize MODEL``: fly it, write the measured profile."""
    from aircraft.characterization import characterize, profile_text
    from analysis.formats.replace import replace_text
    from geofence.validation import ConfigError
    from scenarios.app.cli import check_output_file

    if args.from_params is not None or args.base is not None:
        raise ConfigError(f"characterize {args.model}: --from-params/--base: not with a MODEL to fly (one or the other)")
    if args.kind == "multirotor":
        raise ConfigError(f"characterize {args.model}: --kind multirotor: fixed-wing only in this version")
    if args.out is None:
        raise ConfigError("characterize: --out: required")
    check_output_file(args.out, "--out")
    command = f"geofence-testbed characterize {args.model}"
    if args.aircraft_dir is not None:
        command += f" --aircraft-dir {args.aircraft_dir}"
    result = characterize(args.model, _models_folder(args.aircraft_dir, args.model), progress=print)
    text = profile_text(result, f"{command} --out {args.out}", datetime.datetime.now(datetime.timezone.utc).date())
    replace_text(args.out, text)
    print(f"wrote {args.out} ({result.sim_time_s:.0f} s simulated in {result.wall_time_s:.0f} s wall)")
    return 0


def _models_folder(aircraft_dir: Path | None, model: str) -> Path | None:
    """The folder holding ``MODEL/MODEL.xml`` for ``--aircraft-dir`` (given that folder or the model's own)."""
    from geofence.validation import ConfigError

    if aircraft_dir is None:
        return None
    if not aircraft_dir.is_dir():
        raise ConfigError(f"--aircraft-dir: {aircraft_dir}: not a folder")
    if (aircraft_dir / model / f"{model}.xml").is_file():
        return aircraft_dir
    if (aircraft_dir / f"{model}.xml").is_file() and aircraft_dir.resolve().name == model:
        return aircraft_dir.resolve().parent
    raise ConfigError(f"--aircraft-dir: {aircraft_dir}: holds no {model}/{model}.xml")


def profile_text(params, kind, base, base_name: str, where: str) -> str:
    """The profile YAML (with its provenance header), checked by the project's own profile loader."""
    import yaml

    from aircraft.autopilot_params import base_envelope_values, check_speed_order, derive_envelope
    from aircraft.profile import parse_profile

    found = derive_envelope(params, kind, where)
    env = base_envelope_values(base)
    env.update({k: d.value for k, d in found.items()})
    check_speed_order(env, found, where)
    doc = {"model": base.model, "kind": kind.value, "frame_rate_hz": base.frame_rate_hz, "envelope": env,
           "gains": dict(base.gains)}  # fmt: skip
    parse_profile(doc, base.model, where)  # the loader's own checks, before anything is written
    origin = f"from base profile {base_name} (measured on {base.model}), not measured on this airframe"
    lines = [f"# Profile characterized from the {params.firmware.value} parameters in {where}.", "# Envelope figures:"]
    for key in env:
        lines.append(
            f"#   {key}: " + (f"from {found[key].param} in {where}" if key in found else f"not in the parameters: {origin}")
        )
    lines.append(f"# frame_rate_hz and gains: {origin}.")
    return "\n".join(lines) + "\n" + yaml.safe_dump(doc, sort_keys=False)
