"""Helpers shared by the test modules (the one place they live: test modules do not import each other,
``tests/test_architecture.py`` checks it).

Conformance (compiled vs interpreted): :func:`close_fields`; margins computed two ways (an index and none, a
kernel and its oracle): :func:`same_margins`.

Random fences and states: the frame :data:`FRAME`, the envelopes :data:`FW` (Tern) and :data:`MC` (F450RD),
:func:`latlon`; :func:`random_fence` (noisy star-shaped keep-ins with keep-out squares and circles) and
:func:`dense_fence` (its dense ragged kind), with the states to probe them, :func:`probe_points` and
:func:`dense_states`, and the random arguments of :func:`geofence.margins.boundary_shift.activation_margins` at a
state (:func:`random_margin_call`).

Fixed-wing manoeuvres: :func:`model_path_leaves` (the manoeuvre the margin scores, flown numerically: how deep
it leaves the fence) and :func:`random_flight` (a random fixed-wing state in wind), with :data:`G`.

Multirotor sticks: :func:`fly` (hold a stick command at the :data:`OUTER_HZ` outer loop through the Platform
protocol).

CI suite: :func:`assert_ci_suite_approaches` (the flown ``scenarios/ci`` suite approached every edge, the
ceiling and the floor), with :func:`scenario_local_fence`, :func:`target_edge` and :func:`vertical_room_m`.

Faults: :func:`fault_scenario_doc` (a short scripted flight in a square keep-in, with a ``faults:`` list) and
:func:`fly_doc` (a scenario document parsed and flown).

Golden flights: a scenario under ``tests/data/golden/`` flown in closed loop, its trajectory sampled at
:data:`GOLDEN_STRIDE` and kept as ``<name>.csv`` beside it, compared with tolerances the way JSBSim's own
regression tests compare tables (:func:`compare_golden`).
"""

from __future__ import annotations

import csv
import math
import random
import socket
from collections import defaultdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aircraft.profile import load_profile
from geofence.geometry.fence import Fence, KeepOutCircle
from geofence.geometry.geodesy import LocalFrame
from geofence.physics.rooms import turn_constants, turn_rate_radps, vertical_arrest_distance_m, worst_case_lateral_shift_m

if TYPE_CHECKING:
    from aircraft.multicopter import MulticopterPlatform
    from geofence.interface import StickCommand

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data"
GOLDEN = DATA / "golden"
SHARED_REALWORLD = ROOT.parent / "shared" / "realworld"

GOLDEN_COLUMNS = (
    "time_s", "east_m", "north_m", "up_m", "v_east_mps", "v_north_mps", "v_up_mps", "cmd_roll", "cmd_pitch",
    "cmd_throttle", "geofence_mode", "activation_margin_m",
)  # fmt: skip
GOLDEN_STRIDE = 4
"""Every 4th outer-loop step (10 Hz at the 40 Hz outer loop)."""

GOLDEN_TOLERANCE = {
    "time_s": 1e-9, "east_m": 0.01, "north_m": 0.01, "up_m": 0.01, "v_east_mps": 0.01, "v_north_mps": 0.01,
    "v_up_mps": 0.01, "cmd_roll": 0.01, "cmd_pitch": 0.01, "cmd_throttle": 0.01, "geofence_mode": 0.0,
    "activation_margin_m": 0.01,
}  # fmt: skip
"""Absolute tolerance per column: 1 cm and 1 cm/s, a hundredth of a stick, the mode exactly."""


def golden_table(result) -> np.ndarray:
    """A flight's trajectory as the golden table: :data:`GOLDEN_COLUMNS` at every :data:`GOLDEN_STRIDE`-th row."""
    from scenarios.flight.recorder import COLUMN_INDEX

    data = result.recorder.data[: result.recorder.n]
    return data[::GOLDEN_STRIDE, [COLUMN_INDEX[c] for c in GOLDEN_COLUMNS]]


def write_golden(path: Path, table: np.ndarray) -> None:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(GOLDEN_COLUMNS)
        w.writerows([repr(float(x)) for x in row] for row in table)


def read_golden(path: Path) -> np.ndarray:
    with path.open(newline="") as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == GOLDEN_COLUMNS, f"{path}: columns {rows[0]}"
    return np.array([[float(x) for x in row] for row in rows[1:]])


def compare_golden(got: np.ndarray, want: np.ndarray) -> list[str]:
    """The differences beyond :data:`GOLDEN_TOLERANCE`, one line per column (its worst row); empty when none."""
    if got.shape != want.shape:
        return [f"shape {got.shape} != golden {want.shape}"]
    problems = []
    for j, name in enumerate(GOLDEN_COLUMNS):
        a, b = got[:, j], want[:, j]
        same = (a == b) | (np.isnan(a) & np.isnan(b))  # equal infinities, or both not a number
        with np.errstate(invalid="ignore"):
            err = np.where(same, 0.0, np.abs(a - b))
        err = np.where(np.isnan(err), math.inf, err)
        k = int(np.argmax(err))
        if err[k] > GOLDEN_TOLERANCE[name]:
            problems.append(f"{name}: {a[k]!r} != golden {b[k]!r} at t = {want[k, 0]:.2f} s")
    return problems


FRAME = LocalFrame(47.0, 8.0, 400.0)
FW = load_profile("Tern").envelope
MC = load_profile("F450RD").envelope


def latlon(e, n):
    lat, lon, _ = FRAME.to_geodetic(e, n, FRAME.h0_m)
    return (lat, lon)


def _inside(poly: list[tuple[float, float]], x: float, y: float) -> bool:
    """Even-odd test of a point against a polygon's vertices (for the generator only)."""
    inside = False
    for (ax, ay), (bx, by) in zip(poly, poly[1:] + poly[:1]):
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            inside = not inside
    return inside


def random_fence(seed: int, n_vertices: int, n_squares: int, n_circles: int, dense: bool = False) -> Fence:
    """A noisy star-shaped keep-in of ``n_vertices`` (``dense``: jagged, with notches) with keep-out squares
    (``dense``: their sides cut into short edges) and circles clear of one another inside it."""
    rng = random.Random(seed)
    r0 = rng.uniform(300.0, 900.0) if not dense else rng.uniform(350.0, 700.0)
    keep_in = []
    for i in range(n_vertices):
        a = 2.0 * math.pi * i / n_vertices
        if dense:
            r = r0 * (1.0 + 0.2 * math.sin(3 * a + seed) + 0.03 * math.sin(29 * a)) + rng.uniform(-1.5, 1.5)
            if rng.random() < 0.01:  # a notch: sharp corners
                r -= rng.uniform(5.0, 25.0)
        else:
            r = r0 * (1.0 + 0.25 * math.sin(3 * a + seed) + 0.04 * rng.uniform(-1.0, 1.0))
        keep_in.append((r * math.cos(a), r * math.sin(a)))
    squares, circles, placed = [], [], []
    for _ in range(200):
        if len(squares) >= n_squares and len(circles) >= n_circles:
            break
        a, r = rng.uniform(0, 2 * math.pi), rng.uniform(0.0, 0.55 * r0)
        cx, cy, s = r * math.cos(a), r * math.sin(a), rng.uniform(8.0, 30.0)
        if any(math.hypot(cx - px, cy - py) < s + ps + 10.0 for px, py, ps in placed):
            continue
        if not _inside(keep_in, cx, cy):  # a narrow keep-in (a triangle) may not reach 0.55 r0 everywhere
            continue
        placed.append((cx, cy, s))
        if len(squares) < n_squares:
            t = rng.uniform(0, math.pi)
            cut = rng.randint(1, 12) if dense else 1  # sides cut into short edges
            corners = [(cx + s * math.cos(t + k * math.pi / 2), cy + s * math.sin(t + k * math.pi / 2)) for k in range(4)]
            pts = []
            for k in range(4):
                (ax, ay), (bx, by) = corners[k], corners[(k + 1) % 4]
                pts += [(ax + (bx - ax) * q / cut, ay + (by - ay) * q / cut) for q in range(cut)]
            squares.append(tuple(latlon(x, y) for x, y in pts))
        else:
            circles.append(KeepOutCircle(*latlon(cx, cy), s))
    return Fence(
        keep_in=tuple(latlon(e, n) for e, n in keep_in),
        ceiling_m=120.0,
        keep_out_polygons=tuple(squares),
        keep_out_circles=tuple(circles),
    )


def probe_points(local, rng: random.Random, count: int):
    """Points near vertices and edges (both sides), inside keep-outs, far inside and outside."""
    pts = []
    ki = local.keep_in
    for _ in range(count):
        kind = rng.randrange(5)
        if kind == 0:
            v = ki.vertices[rng.randrange(ki.n)]
            pts.append((v[0] + rng.gauss(0, 3.0), v[1] + rng.gauss(0, 3.0)))
        elif kind == 1:
            i = rng.randrange(ki.n)
            a, b = ki.starts[i], ki.ends[i]
            t = rng.random()
            o = ki.outward_normals[i] * rng.uniform(-40.0, 40.0)
            pts.append((a[0] + t * (b[0] - a[0]) + o[0], a[1] + t * (b[1] - a[1]) + o[1]))
        elif kind == 2 and local.keep_out_polygons:
            k = local.keep_out_polygons[rng.randrange(len(local.keep_out_polygons))]
            c = k.vertices.mean(axis=0)
            pts.append((c[0] + rng.uniform(-25, 25), c[1] + rng.uniform(-25, 25)))
        elif kind == 3 and local.keep_out_circles:
            ce, cn, r = local.keep_out_circles[rng.randrange(len(local.keep_out_circles))]
            pts.append((ce + rng.uniform(-1.5 * r, 1.5 * r), cn + rng.uniform(-1.5 * r, 1.5 * r)))
        else:
            pts.append((rng.uniform(-1500, 1500), rng.uniform(-1500, 1500)))
    return pts


def random_margin_call(
    rng: random.Random, e: float, n: float, env, *, bank_rad: float, wrap_heading: bool = False, rollout: bool = False
) -> tuple[tuple, dict]:
    """Random arguments of :func:`activation_margins` at (e, n): speed up to 1.2 x max in any course (with
    ``wrap_heading``, 1 in 5 at the ±pi wrap), wind up to 9 m/s, uncertainty, latency, bank up to ``bank_rad``,
    wind allowance and (with ``rollout``) a roll-out target: none, anywhere, or the point itself."""
    speed = rng.uniform(0.0, env.max_speed_mps * 1.2)
    course = rng.uniform(-math.pi, math.pi)
    if wrap_heading and rng.random() < 0.2:
        course = math.pi * rng.choice([1.0, -1.0]) * (1.0 - 1e-12 * rng.random())
    w, wd = rng.uniform(0.0, 9.0), rng.uniform(-math.pi, math.pi)
    args = (e, n, 30.0, speed * math.cos(course), speed * math.sin(course), rng.uniform(-3, 3), env)
    args += (w * math.cos(wd), w * math.sin(wd))
    kw = dict(
        h_uncertainty_m=rng.uniform(0, 6),
        v_uncertainty_m=1.0,
        latency_s=rng.uniform(0, 0.3),
        bank_rad=rng.uniform(-bank_rad, bank_rad),
        wind_extra_mps=rng.uniform(0, 3),
    )
    if rollout:
        kw["rollout_target_en"] = rng.choice([None, (rng.uniform(-300, 300), rng.uniform(-300, 300)), (e, n)])
    return args, kw


def dense_fence(seed: int, n_vertices: int, n_squares: int, n_circles: int) -> Fence:
    """A keep-in of closely spaced jagged vertices with notches, keep-out squares cut into short edges."""
    return random_fence(seed, n_vertices, n_squares, n_circles, dense=True)


def dense_states(local, rng: random.Random, count: int):
    """Points next to keep-in vertices (inside and out), next to and inside keep-outs, near circles."""
    ki = local.keep_in
    for _ in range(count):
        kind = rng.randrange(4)
        if kind == 0 or not (local.keep_out_polygons or local.keep_out_circles):
            v = ki.vertices[rng.randrange(ki.n)]
            inward = -ki.outward_normals[rng.randrange(ki.n)]
            depth = rng.choice([rng.uniform(-3.0, 3.0), rng.uniform(0.0, 120.0)])
            yield v[0] + inward[0] * depth + rng.gauss(0, 1.0), v[1] + inward[1] * depth + rng.gauss(0, 1.0)
        elif kind in (1, 2) and local.keep_out_polygons:
            k = local.keep_out_polygons[rng.randrange(len(local.keep_out_polygons))]
            v = k.vertices[rng.randrange(k.n)] if kind == 1 else k.vertices.mean(axis=0)
            yield v[0] + rng.uniform(-12.0, 12.0), v[1] + rng.uniform(-12.0, 12.0)
        elif local.keep_out_circles:
            ce, cn, r = local.keep_out_circles[rng.randrange(len(local.keep_out_circles))]
            yield ce + rng.uniform(-1.5 * r, 1.5 * r), cn + rng.uniform(-1.5 * r, 1.5 * r)


G = 9.80665
"""Standard gravity (m/s^2)."""


def model_path_leaves(local, e, n, ve, vn, we, wn, bank, latency, r, steps: int = 3000, env=FW) -> float:
    """The deepest point outside the allowed area (m, > 0: out) of the manoeuvre :func:`activation_margins` scores
    for a fixed-wing of envelope ``env`` (its reaction phase in the current turn at ``v_turn``, then the turn
    ``r.turn_sign``, ``r.turn_angle_rad`` at the bank limit), flown in the steady wind ``(we, wn)``: every point
    of it."""
    vae, van = ve - we, vn - wn
    psi = math.atan2(van, vae)
    v = max(math.hypot(vae, van), env.cruise_speed_mps, env.min_speed_mps, 1e-3)
    _, inv_omega = turn_constants(v, env.max_bank_rad, G)
    bank_now = max(-env.max_bank_rad, min(env.max_bank_rad, bank))
    t_fw = env.reaction_time_s + latency + env.reaction_time_s * abs(bank_now) / env.max_bank_rad
    rot = max(-math.pi, min(math.pi, turn_rate_radps(v, bank_now, G) * t_fw))
    deepest = -math.inf
    x, y = e, n
    phases = ((t_fw, -rot / t_fw), (r.turn_angle_rad * inv_omega, r.turn_sign / inv_omega))
    for duration, rate in phases:
        dt = duration / steps
        for _ in range(steps):
            x += (v * math.cos(psi + 0.5 * rate * dt) + we) * dt
            y += (v * math.sin(psi + 0.5 * rate * dt) + wn) * dt
            psi += rate * dt
            deepest = max(deepest, -local.lateral_margin_m(x, y))
    return deepest


def random_flight(rng: random.Random, env, max_wind_fraction: float) -> tuple[float, ...]:
    """``(ve, vn, wind_e, wind_n, bank, latency)``: a fixed-wing between cruise and max airspeed on any course, in a
    wind of 0.2 to ``max_wind_fraction`` of its cruise speed from anywhere, banked up to 0.5 rad, 0 to 0.3 s late."""
    speed, course = rng.uniform(env.cruise_speed_mps, env.max_speed_mps), rng.uniform(-math.pi, math.pi)
    w, wd = rng.uniform(0.2, max_wind_fraction) * env.cruise_speed_mps, rng.uniform(-math.pi, math.pi)
    we, wn = w * math.cos(wd), w * math.sin(wd)
    return speed * math.cos(course) + we, speed * math.sin(course) + wn, we, wn, rng.uniform(-0.5, 0.5), rng.uniform(0.0, 0.3)


OUTER_HZ = 40.0
"""The outer loop of :func:`fly` (Hz), the simulation's."""


def fly(pl: MulticopterPlatform, cmd: StickCommand, seconds: float, until=None):
    """Hold ``cmd`` for ``seconds`` (40 Hz outer loop); return the states seen, stop early if ``until(state)``."""
    frames = max(1, round(1.0 / (OUTER_HZ * pl.dt_s)))
    states = []
    for _ in range(int(round(seconds * OUTER_HZ))):
        pl.command(cmd)
        pl.step(frames)
        s = pl.truth()
        states.append(s)
        if until is not None and until(s):
            break
    return states


def scenario_local_fence(sc):
    """The scenario's fence in the local frame at its start."""
    st = sc.start
    return sc.geofence.fence.to_local(LocalFrame(st.lat_deg, st.lon_deg, st.ground_alt_m))


def target_edge(sc, fence) -> tuple[int, float]:
    """(index of the keep-in edge the first segment's course ray hits first from the start, distance m)."""
    seg = sc.pilot.segments[0]
    c = math.radians(seg.course_deg)
    d = np.array([math.sin(c), math.cos(c)])
    k = fence.keep_in
    best = (-1, math.inf)
    for i, (a, b) in enumerate(zip(k.starts, k.ends)):
        # solve o + s d = a + u (b - a), the start o = (0, 0)
        m = np.column_stack([d, a - b])
        if abs(np.linalg.det(m)) < 1e-12:
            continue
        s, u = np.linalg.solve(m, a)
        if s > 0 and -1e-9 <= u <= 1 + 1e-9 and s < best[1]:
            best = (i, float(s))
    return best


def vertical_room_m(sc, rate_mps: float) -> float:
    """Arrest distance at ``rate_mps`` plus k·sigma of the GPS vertical error (bias and white, root-sum-square)."""
    env = sc.profile.envelope
    sigma = math.hypot(sc.sensors.gps_v_bias_m, sc.sensors.gps_v_white_m)
    return (
        vertical_arrest_distance_m(rate_mps, env.reaction_time_s, env.vertical_accel_mps2, rate_mps)
        + sc.geofence.uncertainty_k_sigma * sigma
    )


def assert_ci_suite_approaches(out: Path) -> dict[str, dict[str, float]]:
    """Check the flown CI suite in ``out`` (a batch output folder with ``*/trajectory.csv`` and ``scenario.yaml``):
    each flight's closest approach to its target edge is below 2 x the platform's worst-case lateral activation
    room at that wind (:func:`geofence.physics.rooms.worst_case_lateral_shift_m`), and per platform and wind the ceiling
    and the floor were approached within 2 x the vertical room (:func:`vertical_room_m`). Returns the closest
    approaches per flight. ``tests/test_batch.py`` calls it on the CI-suite batch it flies."""
    from scenarios.definition.schema import parse_scenario, read_document
    from scenarios.flight.recorder import read_trajectory_csv

    folders = sorted(p.parent for p in Path(out).glob("*/trajectory.csv"))
    assert folders, f"{out}: no flights"
    approaches: dict[str, dict[str, float]] = {}
    vertical: dict[tuple[str, float], dict[str, float]] = defaultdict(lambda: {"ceiling": math.inf, "floor": math.inf})
    bounds: dict[tuple[str, float], dict[str, float]] = {}
    for folder in folders:
        sc = parse_scenario(read_document(folder / "scenario.yaml"), str(folder / "scenario.yaml"), folder.name)
        fence = scenario_local_fence(sc)
        env = sc.profile.envelope
        wind = sc.wind.speed_mps if sc.wind else 0.0
        tr = read_trajectory_csv(folder / "trajectory.csv")
        edge, _ = target_edge(sc, fence)
        a, b = fence.keep_in.starts[edge], fence.keep_in.ends[edge]
        normal = fence.keep_in.outward_normals[edge]
        pts = np.column_stack([tr["east_m"], tr["north_m"]])
        inside_by = (a - pts) @ normal  # + inside, distance to the edge's line
        closest = float(inside_by.min())
        room = worst_case_lateral_shift_m(env, wind)
        assert closest < 2.0 * room, (
            f"{folder.name}: closest approach to edge {edge} is {closest:.0f} m, not within 2 x {room:.0f} m of activation room"
        )
        assert np.linalg.norm(b - a) > 0
        ceiling = float(np.min(fence.ceiling_m - tr["agl_m"]))
        floor = float(np.min(tr["agl_m"] - fence.floor_m)) if fence.floor_m is not None else math.inf
        approaches[folder.name] = {
            "edge": edge,
            "lateral_m": closest,
            "lateral_bound_m": 2.0 * room,
            "ceiling_m": ceiling,
            "floor_m": floor,
        }
        key = (sc.aircraft, wind)
        vertical[key]["ceiling"] = min(vertical[key]["ceiling"], ceiling)
        vertical[key]["floor"] = min(vertical[key]["floor"], floor)
        bounds[key] = {
            "ceiling": 2.0 * vertical_room_m(sc, env.max_climb_rate_mps),
            "floor": 2.0 * vertical_room_m(sc, env.max_descent_rate_mps),
        }
    for key, v in vertical.items():
        for which in ("ceiling", "floor"):
            assert v[which] < bounds[key][which], (
                f"{key}: closest approach to the {which} {v[which]:.1f} m, not within {bounds[key][which]:.1f} m"
            )
    return approaches


CONFORMANCE_REL = 1e-12
"""A compiled entry point against its own source interpreted (``.py_func``): the same float operations in the
same order (numba contracts no multiply-adds, the C library's transcendental functions are CPython's), so
equal within this relative tolerance (in practice exactly)."""


def close_fields(a, b, rel: float = CONFORMANCE_REL) -> bool:
    """Every field equal within ``rel`` relative (infinities and NaNs equal to themselves)."""
    for x, y in zip(a, b, strict=True):
        x, y = float(x), float(y)
        if x == y or (math.isnan(x) and math.isnan(y)):
            continue
        if not abs(x - y) <= rel * max(abs(x), abs(y)):
            return False
    return True


SAME_MARGINS_M = 1e-9
"""Two :class:`~geofence.margins.boundary_shift.ShiftResult` computed two ways that must agree (a fence with and without
its index): every float field within this many metres (relative beyond a metre)."""


def same_margins(a, b, tol: float = SAME_MARGINS_M) -> bool:
    """Every float field of two results within ``tol`` (times ``1 + |b|``; infinities and NaNs equal to themselves),
    every string and integer field (the binding element, the turn sign) equal."""
    for x, y in zip(a, b, strict=True):
        if isinstance(x, (str, int)):
            if x != y:
                return False
        elif not (x == y or (math.isnan(x) and math.isnan(y)) or abs(x - y) <= tol * (1.0 + abs(y))):
            return False
    return True


# ---------------------------------------------------------------------------------------------- MAVLink links
def free_udp_port() -> int:
    """A loopback UDP port free at the moment of asking (bound to port 0, then released)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


SQUARE_FENCE_WPL = """QGC WPL 110
0\t0\t0\t5001\t4\t0\t0\t0\t47.3960000\t8.5430000\t0\t1
1\t0\t0\t5001\t4\t0\t0\t0\t47.3960000\t8.5470000\t0\t1
2\t0\t0\t5001\t4\t0\t0\t0\t47.3980000\t8.5470000\t0\t1
3\t0\t0\t5001\t4\t0\t0\t0\t47.3980000\t8.5430000\t0\t1
"""
"""A 300 x 220 m keep-in square near Zurich (the PX4 SITL site) as a WPL 110 fence file, for the link tests."""


def fault_scenario_doc(
    aircraft: str, faults: list | None, *, duration_s: float = 12.0, half_m: float = 400.0, agl_m: float = 60.0,
    start_en: tuple[float, float] = (0.0, 0.0), heading_deg: float = 0.0, segments: list | None = None, seed: int = 3,
) -> dict:  # fmt: skip
    """A scenario document: ``aircraft`` flying scripted ``segments`` (default: centred sticks for the whole flight)
    from ``start_en`` in a keep-in square of half side ``half_m`` about :data:`FRAME`'s origin, with ``faults``."""
    lat, lon, _ = FRAME.to_geodetic(start_en[0], start_en[1], 0.0)
    square = [(-half_m, -half_m), (half_m, -half_m), (half_m, half_m), (-half_m, half_m)]
    hold = {"roll": 0.0, "pitch": 0.0, "yaw": 0.0, "throttle": 0.0}
    doc = {
        "aircraft": aircraft,
        "duration_s": duration_s,
        "seed": seed,
        "start": {"lat_deg": lat, "lon_deg": lon, "ground_alt_m": FRAME.h0_m, "agl_m": agl_m, "heading_deg": heading_deg},
        "pilot": {"type": "scripted", "segments": segments or [{"duration_s": duration_s, "sticks": hold}]},
        "geofence": {"fence": {"keep_in": [list(latlon(e, n)) for e, n in square], "ceiling_m": 150}},
    }
    if faults is not None:
        doc["faults"] = faults
    return doc


def fly_doc(doc: dict, name: str = "fault_case"):
    """Parse a scenario document (as the file ``<name>.yaml``) and fly it: the :class:`FlightResult`."""
    from scenarios.definition.schema import parse_scenario
    from scenarios.flight.runner import fly as fly_scenario

    return fly_scenario(parse_scenario(doc, f"{name}.yaml"))


def point_mass_fall(h_m: float, v_enu: tuple[float, float, float], wind_en: tuple[float, float], terminal_mps: float | None):
    """The independent oracle of a termination fall (:mod:`geofence.physics.termination`): scipy's adaptive RK45
    of a point mass under gravity and quadratic drag against the air (terminal speed ``terminal_mps``; None: no
    drag), from ``h_m`` above the ground; ``(east, north, t)`` where and when it lands, relative to the start."""
    from scipy.integrate import solve_ivp

    g = 9.80665
    c = 0.0 if terminal_mps is None else g / terminal_mps**2

    def rhs(_t, y):
        rel = np.array([y[3] - wind_en[0], y[4] - wind_en[1], y[5]])
        return [y[3], y[4], y[5], *(np.array([0.0, 0.0, -g]) - c * np.linalg.norm(rel) * rel)]

    def ground(_t, y):
        return y[2]

    ground.terminal, ground.direction = True, -1  # type: ignore[attr-defined]
    sol = solve_ivp(rhs, (0.0, 600.0), [0.0, 0.0, h_m, *v_enu], events=ground, rtol=1e-10, atol=1e-10, max_step=0.5)
    y = sol.y_events[0][0]
    return float(y[0]), float(y[1]), float(sol.t_events[0][0])


def edge_run_doc(aircraft: str, faults: list | None, *, agl_m: float, edge_m: float, duration_s: float, pitch: float = 1.0):
    """:func:`fault_scenario_doc` of ``aircraft`` flying north from the square's centre at an edge ``edge_m`` ahead,
    ``agl_m`` up: a fixed-wing at full speed on course, a multirotor on the forward pitch stick ``pitch``."""
    sticks = None
    if load_profile(aircraft).envelope.is_multirotor:
        sticks = {"roll": 0.0, "pitch": -pitch, "yaw": 0.0, "throttle": 0.0}
    seg = (
        {"duration_s": duration_s, "sticks": sticks}
        if sticks
        else {"duration_s": duration_s, "course_deg": 0, "speed": "max", "climb": "hold"}
    )
    return fault_scenario_doc(aircraft, faults, duration_s=duration_s, half_m=edge_m, agl_m=agl_m, segments=[seg])


def rising_wind_doc(half_north_m: float, half_east_m: float, from_deg: float, sensors: bool = True) -> dict:
    """An F450RD 30 m up flying north (pitch stick 0.7) at the north edge of a keep-in rectangle (``half_north_m``,
    ``half_east_m``) in a 4 m/s wind from ``from_deg``, which a gust 1.5 s after the first override raises by 10
    m/s and holds (14 m/s: beyond its 10.3 m/s), the unit told the 4 m/s; ``sensors``: a rangefinder and optical
    flow fitted."""
    seg = [{"duration_s": 90.0, "sticks": {"roll": 0.0, "pitch": -0.7, "yaw": 0.0, "throttle": 0.0}}]
    doc = fault_scenario_doc("F450RD", None, duration_s=90.0, half_m=half_north_m, agl_m=30.0, segments=seg)
    box = [(-half_east_m, -half_north_m), (half_east_m, -half_north_m), (half_east_m, half_north_m), (-half_east_m, half_north_m)]
    doc["geofence"]["fence"]["keep_in"] = [list(latlon(e, n)) for e, n in box]
    gust = {"onset_s": 1.5, "onset_after": "first_activation", "amplitude_mps": 10.0, "length_m": 40.0, "hold_m": math.inf}
    doc["wind"] = {"speed_mps": 4.0, "from_deg": from_deg, "gusts": [gust]}
    doc["geofence"]["wind_prior"] = {"speed_mps": 4.0, "from_deg": from_deg}
    if sensors:
        doc["sensors"] = {"rangefinder": {}, "optical_flow": {}}
    return doc


def only_summary(out: Path) -> dict:
    """The ``summary.json`` of the one flight folder a ``run --out OUT`` of a single scenario wrote."""
    import json

    found = sorted(out.glob("*/summary.json"))
    assert len(found) == 1, f"expected one flight folder in {out}, found {len(found)}"
    return json.loads(found[0].read_text())


def flow_suite(cfg, seed: int = 1):
    """A multirotor's :class:`~aircraft.sensors.SensorSuite` of ``cfg`` over flat ground at :data:`FRAME`'s height."""
    from aircraft.sensors import SensorSuite

    return SensorSuite(cfg, has_pitot=False, seed=seed, ground_alt_m=FRAME.h0_m)


def sample_flow_range(
    cfg, agl_m: float, roll_rad: float = 0.0, v_east_mps: float = 0.0, v_north_mps: float = 0.0,
    yaw_rad: float = 0.0, seed: int = 1,
):  # fmt: skip
    """The rangefinder's and flow's first sample (:class:`~geofence.estimation.measurements.RangeFlowSample`) of a
    suite of ``cfg`` (:func:`flow_suite`) over a vehicle ``agl_m`` above :data:`FRAME`'s origin."""
    from geofence.interface import VehicleState

    lat, lon, alt = FRAME.to_geodetic(0.0, 0.0, agl_m)
    suite = flow_suite(cfg, seed)
    truth = VehicleState(
        t_s=0.0, lat_deg=lat, lon_deg=lon, alt_m=alt, agl_m=agl_m, v_east_mps=v_east_mps, v_north_mps=v_north_mps,
        roll_rad=roll_rad, yaw_rad=yaw_rad,
    )  # fmt: skip
    suite.sample(truth)
    return suite.range_flow()


def gnss_loss_landing(
    aircraft: str, fitted: bool, wind_mps: float = 0.0, toward_edge: bool = False, seed: int = 3, baro_high_m: float = 0.0
) -> dict:  # fmt: skip
    """The summary of a multirotor landing after its GNSS is lost: hovering 20 m up in the middle of a 260 m square
    (lost at 3 s), or ``toward_edge`` flying at an edge of a 240 m square 25 m up (lost 0.5 s into the override);
    ``fitted``: with a rangefinder and optical flow (their defaults); ``baro_high_m``: the barometer reads that much
    high from the loss on (a ``baro_drift`` fault). In a light-turbulence wind from 200 deg."""
    if toward_edge:
        faults = [{"kind": "gnss_loss", "at_first_activation": True, "delay_s": 0.5}]
        forward = [{"duration_s": 45.0, "sticks": {"roll": 0.0, "pitch": -0.6, "yaw": 0.0, "throttle": 0.0}}]
        doc = fault_scenario_doc(aircraft, faults, duration_s=45.0, half_m=120.0, agl_m=25.0, segments=forward, seed=seed)
    else:
        faults = [{"kind": "gnss_loss", "at_s": 3.0}]
        if baro_high_m:
            faults.append({"kind": "baro_drift", "at_s": 3.0, "drift_m": baro_high_m})
        doc = fault_scenario_doc(aircraft, faults, duration_s=40.0, half_m=130.0, agl_m=20.0, seed=seed)
    if fitted:
        doc["sensors"] = {"rangefinder": {}, "optical_flow": {}}
    if wind_mps > 0.0:
        doc["wind"] = {"speed_mps": wind_mps, "from_deg": 200.0, "turbulence": {"severity": "light"}}
    return fly_doc(doc, f"gnss_loss_{aircraft}").summary
