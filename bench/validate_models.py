"""Model validation: fly every platform through its standard manoeuvres and write docs/validation.md.

A thin wrapper around :func:`aircraft.validation.run_validation`: the measured
values per platform (top speed, stop distance, wind pick-up, climb, turn,
glide, landing gear ...) next to published reference bands, and with
``--check-profiles`` a comparison of each profile's envelope with what was
measured (exit 1 if any figure is off by more than its tolerance).

    python3 bench/validate_models.py [--models F450RD Micro250 ...] [--out docs/validation.md]
                                     [--check-profiles [--allow-conservative]] [--tolerance-scale 1.0]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from aircraft.validation import default_models, run_validation  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--models", nargs="+", metavar="MODEL", help=f"profile names to fly (default: all: {' '.join(default_models())})"
    )
    ap.add_argument(
        "--out", default="docs/validation.md", help="markdown file to write (default: docs/validation.md); '' to skip"
    )
    ap.add_argument(
        "--check-profiles",
        action="store_true",
        help="compare each profile's envelope with the measured one; exit 1 on a mismatch",
    )
    ap.add_argument(
        "--allow-conservative",
        action="store_true",
        help="with --check-profiles: a figure off on the geofence's safe side (e.g. a smaller "
        "braking deceleration than measured) is reported but does not fail",
    )
    ap.add_argument("--tolerance-scale", type=float, default=1.0, help="multiply every envelope tolerance by this (default 1)")
    args = ap.parse_args(argv)
    return run_validation(
        args.models,
        out=args.out or None,
        check_profiles=args.check_profiles,
        tolerance_scale=args.tolerance_scale,
        allow_conservative=args.allow_conservative,
        progress=lambda s: print(s, flush=True),
    )


if __name__ == "__main__":
    sys.exit(main())
