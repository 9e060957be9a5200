"""The ``characterize`` command: an airframe's profile YAML from its autopilot parameter file.

Owns the subparser and the writing of the profile (header comment per figure: which parameter gave it, or
which base profile it was taken from). The parsing and mapping live in :mod:`aircraft.autopilot_params`.
Flying a model to measure its envelope (``characterize MODEL``) is not built yet and is refused.
"""

from __future__ import annotations

from pathlib import Path

DEFAULT_BASE = {"multirotor": "F450", "fixed_wing": "c172x"}


def register(sub) -> None:
    """Add the ``characterize`` subparser; its handler is ``args.handler``."""
    p = sub.add_parser(
        "characterize",
        help="write an airframe's profile from its ArduPilot/PX4 parameter file",
        description=(
            "Read an ArduPilot .param file (NAME VALUE or NAME,VALUE lines) or a PX4 QGroundControl .params export "
            "and write a profile YAML (the format of aircraft/profiles/*.yaml) whose envelope holds the limits the "
            "parameters set: tilt/bank, pitch, cruise/min/max speed, climb and descent rate (and for PX4 "
            "multicopters horizontal braking and yaw rate). Figures the parameters cannot give, and the flight-"
            "controller gains, come from --base and are marked so in the file's header. Parameters that break the "
            "envelope's rules (e.g. cruise above max speed) are refused with one line (exit 2). "
            "Flying a MODEL to measure its envelope is not built yet: only --from-params works."
        ),
    )
    p.add_argument("model", nargs="?", metavar="MODEL", help="(not built yet) a JSBSim model to fly and measure")
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
        raise ConfigError(f"characterize {args.model}: flying a model to measure it is not built yet; use --from-params FILE")
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
