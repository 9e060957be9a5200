"""Benchmark: geofence unit cost per update against fence size: indexed and unindexed, side by side.

For fences of one family -- a noisy star-shaped keep-in about 6 km across with
``V`` vertices and ``K`` square keep-outs (20-40 m buildings on a jittered grid)
-- it times :meth:`GeofenceUnit.update` per call for the two platform kinds
(the F450RD and Tern profiles' envelopes) in a 6 m/s wind:

* ``near``: the vehicle flies along the boundary at cruise speed, closing on it
  (the outward component of the velocity is a third of the speed), at a
  distance where the activation margin stays positive (so the unit keeps
  monitoring and computes the full margin every step); the position advances
  every call at the 40 Hz outer-loop step, so cache-cell changes are paid at
  the rate a real flight pays them (:data:`INDEX_CALLS` calls with the index; the
  fixed-wing's route searches per cell included, its route graph built before);
* ``far``: the same at the fence's centre (the skip shortcut answers).

Each case runs three ways in the same run: with the fence index and the
compiled search (``index``, what a flight uses from
:data:`geofence.geometry.fence_grid.SMALL_FENCE_ELEMENTS` elements on), with the index
and with the full scan of
every element (``scan``, no index: what a flight uses below that, its whole
margin one compiled call); medians of repeats. It prints a table and saves
``bench/fence_scale.png`` (log-log).

    python bench/fence_scale.py [--repeats 3]            # the full run: table and bench/fence_scale.png
    python bench/fence_scale.py --sizes 100x0,10000x500   # some sizes: the table only (--out PATH for a figure)
    python bench/fence_scale.py --plot-from run1.txt run2.txt   # the figure from saved tables
"""

from __future__ import annotations

import argparse
import math
import random
import statistics
import time
from pathlib import Path

from aircraft.profile import load_profile
from geofence.geometry.fence import Fence
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import StickCommand, VehicleState
from geofence.unit.config import GeofenceConfig
from geofence.unit.geofence_unit import GeofenceUnit

FRAME = LocalFrame(47.0, 8.0, 400.0)
RADIUS_M = 3000.0
DT_S = 1.0 / 40.0
WIND_EN = (6.0 * math.cos(0.7), 6.0 * math.sin(0.7))
PLATFORMS = ("F450RD", "Tern")
DEFAULT_FIGURE = Path(__file__).with_name("fence_scale.png")
VARIANTS = ("index", "scan")
"""Per case: the index with the compiled search, and the full scan (no index, compiled)."""
INDEX_CALLS = 2_000
"""Updates timed per case with the index: 50 s of flight, some 850 m along the boundary at the Tern's cruise speed.
Long enough to meet stretches where the fixed-wing's route to the recovery point bends round keep-outs (a route
search per 10 m cell); the first 400 calls (the earlier length) of the 10,000-vertex park met none, and showed a
cost 80 times below the whole run's (measured 2026-11-26)."""
CITY_LIMIT_KEEP_OUTS = 1_000
"""Above this many keep-outs the fixed-wing's Python and full-scan cases are skipped (nan): its margin needs the
roll-out target, the first point of a recovery route, and from the middle of 5,000 buildings the planner's graph
search with the vectorised segment tests ran for minutes (measured 2026-11-26; compiled, about a second)."""

PLANNER_LIMIT_ELEMENTS = 20_000
"""Above this many fence elements the fixed-wing's full-scan case is skipped (nan): its margin needs the
recovery-route planner's roll-out target, and the planner tests every corner of the fence against every element
when it is built, hours at 100,000 without the index (with it, about 5 s and 0.6 GB: measured 2026-11-26)."""


def star_fence(n_vertices: int, n_keepouts: int, seed: int = 1) -> Fence:
    rng = random.Random(seed)
    ll = lambda e, n: tuple(FRAME.to_geodetic(e, n, FRAME.h0_m)[:2])  # noqa: E731
    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        keep_in.append(ll(*_boundary(a)))
    squares = []
    if n_keepouts:
        side = math.ceil(math.sqrt(n_keepouts / 0.5))
        step = 1.4 * RADIUS_M * 0.8 / side
        cells = [(i, j) for i in range(side) for j in range(side)]
        rng.shuffle(cells)
        for i, j in cells:
            if len(squares) >= n_keepouts:
                break
            cx = (i - side / 2 + 0.5) * step + rng.uniform(-0.2, 0.2) * step
            cy = (j - side / 2 + 0.5) * step + rng.uniform(-0.2, 0.2) * step
            if math.hypot(cx, cy) > 0.6 * RADIUS_M or math.hypot(cx, cy) < 100.0:
                continue
            s, t = rng.uniform(10.0, 20.0), rng.uniform(0.0, math.pi / 2)
            squares.append(
                tuple(ll(cx + s * math.cos(t + k * math.pi / 2), cy + s * math.sin(t + k * math.pi / 2)) for k in range(4))
            )
    return Fence(keep_in=tuple(keep_in), ceiling_m=120.0, keep_out_polygons=tuple(squares))


def _boundary(a: float) -> tuple[float, float]:
    r = RADIUS_M * (1.0 + 0.15 * math.sin(5.0 * a) + 0.03 * math.sin(37.0 * a))
    return r * math.cos(a), r * math.sin(a)


_INSETS: dict[tuple, float] = {}
"""The inset found per fence and platform (by the first variant, with the most calls: a shorter run's path is a
prefix of it): the variants of a case fly the same states, and the full scan's search would take minutes."""


def moving_states(unit: GeofenceUnit, near: bool, n: int) -> list[VehicleState]:
    """States along the boundary (or at the centre), advancing at cruise speed per 40 Hz step."""
    env = unit.env
    v = env.cruise_speed_mps
    out = []
    a = 0.3
    inset = None
    for k in range(n):
        if not near:
            e, nn = 0.0, 0.0
            ve, vn = v * math.cos(0.3 * k * DT_S), v * math.sin(0.3 * k * DT_S)
        else:
            be, bn = _boundary(a)
            r = math.hypot(be, bn)
            if inset is None:
                f = unit.fence.fence
                key = (id(f), len(f.keep_in), len(f.keep_out_polygons), unit.env)  # the same fence, platform: inset
                inset = _INSETS.get(key)
                if inset is None:
                    inset = _INSETS[key] = _inset_for_positive_margin(unit, a, v, n)
            e, nn = be * (r - inset) / r, bn * (r - inset) / r
            ue, un = be / r, bn / r
            te, tn = -un, ue
            ve, vn = v * (0.94 * te + 0.33 * ue), v * (0.94 * tn + 0.33 * un)
            a += v * DT_S / r
        out.append(
            VehicleState(
                t_s=k * DT_S,
                east_m=e,
                north_m=nn,
                alt_m=FRAME.h0_m + 40.0,
                agl_m=40.0,
                v_east_mps=ve,
                v_north_mps=vn,
                airspeed_mps=v,
            )
        )
    return out


def _inset_for_positive_margin(unit: GeofenceUnit, a: float, v: float, steps: int) -> float:
    """A distance inside the boundary where the activation margin is a few metres positive all along."""
    for inset in range(5, 2000, 5):
        ok = True
        for k in range(0, steps, 10):
            aa = a + k * v * DT_S / RADIUS_M
            be, bn = _boundary(aa)
            r = math.hypot(be, bn)
            e, n = be * (r - inset) / r, bn * (r - inset) / r
            ue, un = be / r, bn / r
            s = VehicleState(
                east_m=e,
                north_m=n,
                agl_m=40.0,
                alt_m=FRAME.h0_m + 40.0,
                v_east_mps=v * (-0.94 * un + 0.33 * ue),
                v_north_mps=v * (0.94 * ue + 0.33 * un),
                airspeed_mps=v,
            )
            if unit._margins(s, 40.0, 1.0, 1.0, DT_S).activation_margin_m < 3.0:
                ok = False
                break
        if ok:
            return float(inset) + 5.0
    raise RuntimeError("no inset with a positive activation margin")


def time_updates(fence: Fence, platform: str, near: bool, index: bool, calls: int) -> tuple[float, int]:
    """(µs per update, activations) over ``calls`` updates of a moving vehicle."""
    local = fence.to_local(FRAME, index=index)
    env = load_profile(platform).envelope
    unit = GeofenceUnit(GeofenceConfig(fence=fence, wind_prior_enu=WIND_EN), local, env)
    states = moving_states(unit, near, calls)
    pilot = StickCommand()
    update = unit.update
    for s in states[:5]:  # warm-up: density scaling, first cell
        update(s.t_s, s, pilot, DT_S, WIND_EN, True, 1.0, 1.0)
    unit.prepare_routes()  # the route graph's one-time build (a flight pays it at its first route search)
    t0 = time.perf_counter()
    for s in states:
        update(s.t_s, s, pilot, DT_S, WIND_EN, True, 1.0, 1.0)
    dt = time.perf_counter() - t0
    return 1e6 * dt / len(states), unit.activations


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer sizes and calls (a smoke run)")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved repeats, median reported (default 3)")
    ap.add_argument(
        "--out",
        type=Path,
        default=None,
        help="figure path (default bench/fence_scale.png for a full run or --plot-from; a --sizes or --quick run draws"
        " no figure unless given one, so it never replaces the full run's)",
    )
    ap.add_argument(
        "--sizes",
        default=None,
        metavar="VxK,...",
        help="fence sizes to run, keep-in vertices x keep-outs (default: the full list)",
    )
    ap.add_argument(
        "--plot-from",
        nargs="+",
        type=Path,
        default=None,
        metavar="TABLE",
        help="draw the figure from tables this script printed (no measuring)",
    )
    args = ap.parse_args()
    if args.plot_from:
        rows = [r for path in args.plot_from for r in _read_table(path)]
        out = args.out or DEFAULT_FIGURE
        _plot(sorted(rows, key=lambda r: (r[1], r[0])), out)
        print(f"figure: {out}")
        return
    if args.sizes:
        try:
            sizes = [tuple(int(x) for x in item.split("x", 1)) for item in args.sizes.split(",")]
        except ValueError:
            ap.error(f"--sizes: expected VERTICESxKEEPOUTS[,...] such as 100x0,10000x500, got {args.sizes!r}")
        if any(len(s) != 2 or s[0] < 3 or s[1] < 0 for s in sizes):
            ap.error(f"--sizes: each size needs at least 3 vertices and 0 or more keep-outs, got {args.sizes!r}")
    elif args.quick:
        sizes = [(4, 0), (100, 0), (1000, 0), (10000, 500)]
    else:
        sizes = [
            (4, 0),
            (10, 0),
            (100, 0),
            (1000, 0),
            (10000, 0),
            (100000, 0),
            (1000, 50),
            (1000, 500),
            (1000, 5000),
            (10000, 500),
        ]
    rows = []
    print(
        f"{'vertices':>9s} {'keep-outs':>9s} {'build s':>8s}  "
        + "  ".join(f"{p + ' ' + w + ' µs: index/scan':>22s}" for p in PLATFORMS for w in ("near", "far"))
    )
    for nv, nk in sizes:
        t0 = time.perf_counter()
        fence = star_fence(nv, nk)
        build = time.perf_counter() - t0
        cells = []
        for platform in PLATFORMS:
            for near in (True, False):
                res = {}
                for variant in VARIANTS:
                    if platform == "Tern" and (
                        (variant != "index" and nk > CITY_LIMIT_KEEP_OUTS)
                        or (variant == "scan" and nv + 4 * nk > PLANNER_LIMIT_ELEMENTS)
                    ):
                        res[variant] = (math.nan, 0)  # see CITY_LIMIT_KEEP_OUTS, PLANNER_LIMIT_ELEMENTS
                        continue
                    index = variant != "scan"
                    # a full scan of 100k elements costs ~0.1 s per call: time fewer calls there
                    calls = INDEX_CALLS if (index or nv + 4 * nk <= 2000) else (60 if nv + 4 * nk <= 30000 else 12)
                    if args.quick:
                        calls = min(calls, 200)
                    runs = [time_updates(fence, platform, near, index, calls) for _ in range(args.repeats)]
                    res[variant] = (statistics.median(r[0] for r in runs), max(r[1] for r in runs))
                cells.append((platform, near, *(res[v][0] for v in VARIANTS), sum(res[v][1] for v in VARIANTS)))
        rows.append((nv, nk, build, cells))
        print(f"{nv:9d} {nk:9d} {build:8.1f}  " + "  ".join(_cell_text(c) for c in cells), flush=True)
    print("(! = the unit activated during the run: the case measured an override, not monitoring;")
    print(
        f" nan = not measured: the fixed-wing's full scan above {CITY_LIMIT_KEEP_OUTS:,} keep-outs and its"
        f" full scan above {PLANNER_LIMIT_ELEMENTS:,} elements, see CITY_LIMIT_KEEP_OUTS and PLANNER_LIMIT_ELEMENTS)"
    )
    partial = bool(args.sizes or args.quick)
    if partial and args.out is None:
        print(f"figure: not drawn (a partial run; --out PATH draws it, {DEFAULT_FIGURE.name} keeps the full run's)")
        return
    out = args.out or DEFAULT_FIGURE
    _plot(rows, out)
    print(f"figure: {out}")


def _cell_text(c: tuple) -> str:
    """One platform and position's ``index / scan`` µs, ``!`` if the unit activated."""
    return f"{c[2]:10.1f} / {c[3]:9.1f}" + ("!" if c[4] else " ")


def _read_table(path: Path) -> list:
    """The rows of a table this script printed: ``(vertices, keep_outs, build_s, cells)``."""
    rows = []
    n_var = len(VARIANTS)
    for line in path.read_text().splitlines():
        parts = line.replace("!", " ").replace("/", " ").split()
        if len(parts) != 3 + 4 * n_var or not parts[0].isdigit():
            continue
        nv, nk, build = int(parts[0]), int(parts[1]), float(parts[2])
        vals = [float(x) for x in parts[3:]]
        cells = [
            (p, near, *vals[n_var * k : n_var * (k + 1)], 0)
            for k, (p, near) in enumerate((p, w) for p in PLATFORMS for w in (True, False))
        ]
        rows.append((nv, nk, build, cells))
    return rows


def _plot(rows, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    styles = {
        ("F450RD", True): ("tab:blue", "o"),
        ("F450RD", False): ("tab:cyan", "s"),
        ("Tern", True): ("tab:red", "o"),
        ("Tern", False): ("tab:orange", "s"),
    }
    for ax, sel, xlabel, xi in (
        (axes[0], lambda r: r[1] == 0, "keep-in vertices (no keep-outs)", 0),
        (axes[1], lambda r: r[0] == 1000, "keep-out polygons (1,000 keep-in vertices; 0 drawn at 1)", 1),
    ):
        part = [r for r in rows if sel(r)]
        if not part:
            continue
        xs = [max(r[xi], 1) for r in part]
        for k, (platform, near) in enumerate((p, w) for p in PLATFORMS for w in (True, False)):
            colour, marker = styles[(platform, near)]
            label = f"{platform} {'near edge' if near else 'far'}"
            ax.plot(xs, [r[3][k][2] for r in part], color=colour, marker=marker, label=label + ", index")
            ax.plot(xs, [r[3][k][3] for r in part], color=colour, marker=marker, ls=":", alpha=0.5, label=label + ", full scan")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("GeofenceUnit.update, µs per call")
        ax.grid(True, which="both", alpha=0.3)
    for r in rows:
        if r[0] == 10000 and r[1] == 500:  # the target size, beside the keep-in-only line
            for k, (platform, near) in enumerate((p, w) for p in PLATFORMS for w in (True, False)):
                if near and r[3][k][2] == r[3][k][2]:
                    axes[0].plot(
                        [10000],
                        [r[3][k][2]],
                        marker="*",
                        ms=13,
                        ls="none",
                        color=styles[(platform, near)][0],
                        label=f"{platform} near, + 500 keep-outs, index",
                    )
    for k, (platform, near) in enumerate((p, w) for p in PLATFORMS for w in (True, False)):
        base = [r[3][k][2] for r in rows if r[0] == 100 and r[1] == 0]
        if near and base and base[0] == base[0]:  # the target: within 2x of the 100-vertex cost
            axes[0].axhline(
                2.0 * base[0],
                color=styles[(platform, near)][0],
                ls="-.",
                lw=0.9,
                alpha=0.6,
                label=f"{platform}: 2 × its indexed 100-vertex cost (the target)",
            )
    axes[0].legend(fontsize=7, ncol=2)
    fig.suptitle(
        "Geofence cost per update vs fence size (solid: indexed; dotted: full scan)",
        fontsize=10,
    )
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main()
