"""Continuous Dryden turbulence, MIL-F-8785C / MIL-HDBK-1797 low-altitude form.

Scales (h = height above ground in ft, clamped to [min_height, 1000 ft]):

    L_w = h,            L_u = L_v = h / (0.177 + 0.000823 h) ** 1.2      (ft)
    sigma_w = 0.1 W20,  sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h) ** 0.4

with W20 the wind speed at 20 ft: 15 / 30 / 45 kt for light / moderate /
severe. Lengths are converted to m (x 0.3048); the sigma ratios are
dimensionless, so sigma is in m/s when W20 is. Above 1000 ft the values at
1000 ft are held (there L_u = L_v = L_w = 1000 ft and sigma_u = sigma_w, the
isotropic limit; the spec's medium/high-altitude model is not needed below the
small-UAS ceiling). Below ``min_height_m`` (default 10 ft) h is clamped, so the
turbulence neither vanishes nor gets infinitely fast at the ground.

Spectra (spatial frequency Omega, rad/m), each integrating to sigma**2:

    Phi_u = sigma_u**2 (2 L_u / pi) / (1 + (L_u Omega)**2)
    Phi_v = sigma_v**2 (L_v / pi) (1 + 3 (L_v Omega)**2) / (1 + (L_v Omega)**2)**2   (same for w)

i.e. autocorrelations R_u(x) = sigma_u**2 exp(-x/L_u) and R_v(x) =
sigma_v**2 (1 - x / (2 L_v)) exp(-x/L_v). Note the integral scale of v and w is
L/2, that of u is L.

Time: frozen turbulence passes the aircraft at V = max(airspeed, mean wind
speed at h, ``min_speed_mps``) (default 1 m/s), so a hovering vehicle in wind
sees it convected by the wind and one in calm air still sees some; the time
constants are tau = L / V.

Discretization: **exact** (zero-order-hold on the white noise is not used;
the discrete process has exactly the continuous process's covariance at the
sample times, for any step):

* u: Ornstein-Uhlenbeck, x <- a x + sqrt(1 - a**2) n, a = exp(-dt/tau_u).
* v, w: H(s) ~ (1 + sqrt(3) tau s) / (1 + tau s)**2 realized as two cascaded
  first-order lags x1 = 1/(1+tau s) [white], x2 = 1/(1+tau s) [x1], output
  (sqrt(3) x1 + (1 - sqrt(3)) x2) / sqrt(2). With the input scaled so that
  var(x1) = 1, the stationary covariance is P = [[1, 1/2], [1/2, 1/2]];
  the transition is Phi = exp(-r) [[1, 0], [r, 1]] with r = dt/tau, and the
  process noise is Q = P - Phi P Phi^T (closed form below), applied through
  its 2x2 Cholesky factor.

The states are normalized (unit-variance processes in scaled time) and the
sigmas multiply the outputs, so changing height or airspeed never causes a
variance transient, and any dt (a 40 Hz loop, an irregular one, or one huge
jump) gives correctly distributed values. This is why the exact form is used
rather than Tustin: Tustin warps the spectrum near Nyquist and needs
re-derivation whenever dt or tau changes, which happens every step here.

Axes: u along the mean horizontal wind at h (north if calm), v 90 deg to its
left (counter-clockwise seen from above), w up; rotated to ENU on output.

Noise: standard normals from ``numpy.random.default_rng(seed)``, drawn in
blocks of :data:`POOL_NORMALS` and consumed five per step, so a given seed and
sequence of sample times reproduces the same series. The state starts from the
stationary distribution (no start-up transient).

Written once: a sample is :func:`dryden_sample`, a compiled function over the
:data:`DRYDEN` record (the constants, the filter states, the last sample) and
the noise pool; :class:`DrydenTurbulence` is the façade that owns that memory
(or lives in a caller's slice of it: the compiled sampler
:mod:`wind.field_kernel`) and draws the noise blocks.
"""

from __future__ import annotations

import math
from math import exp, expm1, sqrt

import numpy as np

from geofence.jit import compiled, jitable
from wind.field import ZERO, Vec3, WindField, convection_speed_mps

FT_M = 0.3048
KT_MPS = 1852.0 / 3600.0

#: W20 (wind speed at 20 ft) for the MIL-F-8785C severity levels, m/s.
SEVERITY_W20_MPS: dict[str, float] = {"light": 15.0 * KT_MPS, "moderate": 30.0 * KT_MPS, "severe": 45.0 * KT_MPS}

_SQRT3 = math.sqrt(3.0)
OUTPUT_WEIGHTS = (_SQRT3 / math.sqrt(2.0), (1.0 - _SQRT3) / math.sqrt(2.0))
"""The output weights ``(c1, c2)`` of the normalized second-order (v, w) filters: ``c1 x1 + c2 x2``."""
NORMALS_PER_STEP = 5
"""Standard normals a sample draws: one for u, two each for v and w."""
POOL_NORMALS = NORMALS_PER_STEP * 2048
"""Normals drawn from the generator at a time (a block)."""
H_MAX_FT = 1000.0
"""The top of the low-altitude model (ft): above it the scales of 1,000 ft hold."""


def dryden_scales(up_m: float, w20_mps: float, min_height_m: float = 10.0 * FT_M) -> tuple[float, float, float, float]:
    """(L_u = L_v in m, L_w in m, sigma_u = sigma_v in m/s, sigma_w in m/s) at height ``up_m`` AGL."""
    return _scales(up_m, min_height_m / FT_M, 0.1 * w20_mps)


@jitable
def _scales(up_m: float, hmin_ft: float, sigma_w: float) -> tuple[float, float, float, float]:
    """:func:`dryden_scales` with the floor height in ft and ``sigma_w = 0.1 W20`` (a turbulence's constants)."""
    h = up_m / FT_M
    if not h > hmin_ft:  # also catches NaN
        h = hmin_ft
    elif h > H_MAX_FT:
        h = H_MAX_FT
    d = 0.177 + 0.000823 * h
    return h * FT_M / d**1.2, h * FT_M, sigma_w / d**0.4, sigma_w


@jitable
def _coefficients(r: float) -> tuple[float, float, float, float]:
    """``(a, l11, l21, l22)``: the exact discretisation of a unit-variance filter over ``r = dt / tau``, its
    decay ``a = exp(-r)`` and the Cholesky factor of the step's noise covariance (see the module docstring)."""
    a = exp(-r)
    q11 = -expm1(-2.0 * r)  # 1 - a^2, accurate for small r
    l11 = sqrt(q11)
    a2 = a * a
    q12 = 0.5 * q11 - a2 * r
    l21 = q12 / l11
    q22 = 0.5 * q11 - a2 * r * (r + 1.0) - l21 * l21
    l22 = sqrt(q22) if q22 > 0.0 else 0.0
    return a, l11, l21, l22


@jitable
def _advance(
    state: tuple[float, float, float, float, float], r_u: float, r_w: float, n0: float, n1: float, n2: float, n3: float, n4: float
) -> tuple[float, float, float, float, float]:
    """The filter states ``(xu, xv1, xv2, xw1, xw2)`` one step on: ``r_u = V dt / L_u`` (u and v), ``r_w = V dt / L_w``,
    driven by the step's five standard normals."""
    xu, xv1, xv2, xw1, xw2 = state
    a, l11, l21, l22 = _coefficients(r_u)
    xu = a * xu + l11 * n0
    x1 = xv1
    xv1 = a * x1 + l11 * n1
    xv2 = a * (r_u * x1 + xv2) + l21 * n1 + l22 * n2
    a, l11, l21, l22 = _coefficients(r_w)
    x1 = xw1
    xw1 = a * x1 + l11 * n3
    xw2 = a * (r_w * x1 + xw2) + l21 * n3 + l22 * n4
    return xu, xv1, xv2, xw1, xw2


@jitable
def turbulence_step(
    state: tuple[float, float, float, float, float],
    started: bool,
    dt_s: float,
    mean_e: float,
    mean_n: float,
    up_m: float,
    airspeed_mps: float,
    min_speed_mps: float,
    hmin_ft: float,
    sigma_w: float,
    n0: float,
    n1: float,
    n2: float,
    n3: float,
    n4: float,
) -> tuple[tuple[float, float, float, float, float], tuple[float, float, float]]:
    """``(filter states, (east, north, up) m/s)`` of one sample (the one home of the step, for
    :class:`DrydenTurbulence` and the compiled sampler :mod:`wind.field_kernel`): the convection speed
    ``max(airspeed, |mean wind|, floor)``, the scales at ``up_m``, the states ``dt_s`` on from ``state`` (or, not
    ``started``, drawn from the stationary distribution) by the step's five normals, and the output on the mean
    wind's axes (north-aligned in calm air)."""
    wspd = sqrt(mean_e * mean_e + mean_n * mean_n)
    v = convection_speed_mps(airspeed_mps, min_speed_mps, wspd)
    lu, lw, su, sw = _scales(up_m, hmin_ft, sigma_w)
    if not started:  # start from the stationary distribution
        state = (n0, n1, 0.5 * (n1 + n2), n3, 0.5 * (n3 + n4))
    else:  # u (and v, which shares L) over r = V dt / L_u, w over V dt / L_w
        state = _advance(state, v * dt_s / lu, v * dt_s / lw, n0, n1, n2, n3, n4)
    xu, xv1, xv2, xw1, xw2 = state
    c1, c2 = OUTPUT_WEIGHTS
    tu = su * xu
    tv = su * (c1 * xv1 + c2 * xv2)
    tw = sw * (c1 * xw1 + c2 * xw2)
    if wspd > 1e-9:
        ce, cn = mean_e / wspd, mean_n / wspd
    else:
        ce, cn = 0.0, 1.0
    return state, (tu * ce - tv * cn, tu * cn + tv * ce, tw)


DRYDEN = np.dtype(
    (
        np.record,
        [
            ("min_speed_mps", np.float64),  # the constants: the convection speed's floor
            ("hmin_ft", np.float64),  # the floor height of the scales
            ("sigma_w_mps", np.float64),  # 0.1 W20
            ("has_t", np.float64),  # 1 once sampled: t_s and the filter states hold
            ("t_s", np.float64),  # the last sample's time
            ("xu", np.float64),  # the unit-variance filter states
            ("xv1", np.float64),
            ("xv2", np.float64),
            ("xw1", np.float64),
            ("xw2", np.float64),
            ("east_mps", np.float64),  # the last sample (ENU)
            ("north_mps", np.float64),
            ("up_mps", np.float64),
            ("pool_index", np.float64),  # the next unused normal of the pool
        ],
    )
)
"""A turbulence's constants and state, a record over float memory (a flag is 0 or 1)."""
DRYDEN_SIZE = DRYDEN.itemsize // 8
"""Float64 slots of the memory a :class:`DrydenTurbulence` lives in."""


@compiled
def dryden_sample(
    D: np.ndarray, pool: np.ndarray, t_s: float, up_m: float, airspeed_mps: float, mean_e: float, mean_n: float
) -> tuple[float, float, float, bool]:
    """``(east, north, up m/s, the pool runs low)``: the turbulence at ``t_s`` and height ``up_m`` of the state
    ``D`` (:data:`DRYDEN`'s slots, advanced in place) in the mean wind ``(mean_e, mean_n)``, by
    :func:`turbulence_step` and the pool's next five normals; the same time again gives the last sample. "Low":
    fewer than five normals are left for the next step (draw the next block)."""
    d = D.view(DRYDEN)[0]
    has_last = d.has_t != 0.0
    last = d.t_s
    if has_last and t_s == last:
        return d.east_mps, d.north_mps, d.up_mps, d.pool_index + NORMALS_PER_STEP > pool.shape[0]
    if has_last and not t_s > last:
        raise ValueError("DrydenTurbulence.sample: time went backwards; call reset()")
    i = int(d.pool_index)
    state, out = turbulence_step(
        (d.xu, d.xv1, d.xv2, d.xw1, d.xw2), has_last, t_s - last if has_last else 0.0, mean_e, mean_n, up_m,
        airspeed_mps, d.min_speed_mps, d.hmin_ft, d.sigma_w_mps, pool[i], pool[i + 1], pool[i + 2], pool[i + 3],
        pool[i + 4],
    )  # fmt: skip
    d.pool_index = i + NORMALS_PER_STEP
    d.xu, d.xv1, d.xv2, d.xw1, d.xw2 = state
    d.t_s = t_s
    d.has_t = 1.0
    d.east_mps, d.north_mps, d.up_mps = out
    return out[0], out[1], out[2], d.pool_index + NORMALS_PER_STEP > pool.shape[0]


class DrydenTurbulence:
    """Seeded Dryden turbulence (zero mean), a :class:`~wind.field.WindField`.

    Give either ``w20_mps`` (wind speed at 20 ft, m/s) or ``severity``
    (``"light"``, ``"moderate"``, ``"severe"``). ``mean_wind`` (usually the
    scenario's steady wind) sets the turbulence axes and the convection speed;
    without it the axes are north-aligned and V = max(airspeed, floor).
    ``memory``: :data:`DRYDEN_SIZE` contiguous float64 slots to live in (a
    caller's compiled step reads and writes the same state); fresh when omitted.
    """

    __slots__ = ("w20_mps", "seed", "mean_wind", "min_speed_mps", "min_height_m", "memory", "pool", "_rng", "_mean_fn")

    def __init__(
        self,
        w20_mps: float | None = None,
        *,
        severity: str | None = None,
        seed: int | np.random.SeedSequence = 0,
        mean_wind: WindField | None = None,
        min_speed_mps: float = 1.0,
        min_height_m: float = 10.0 * FT_M,
        memory: np.ndarray | None = None,
    ) -> None:
        if (w20_mps is None) == (severity is None):
            raise ValueError("DrydenTurbulence: give exactly one of w20_mps or severity")
        if severity is not None:
            if severity not in SEVERITY_W20_MPS:
                raise ValueError(f"turbulence severity must be one of {', '.join(SEVERITY_W20_MPS)}, got {severity!r}")
            w20_mps = SEVERITY_W20_MPS[severity]
        assert w20_mps is not None
        if not (math.isfinite(w20_mps) and w20_mps >= 0.0):
            raise ValueError(f"turbulence w20_mps must be >= 0, got {w20_mps!r}")
        if not (math.isfinite(min_speed_mps) and min_speed_mps > 0.0):
            raise ValueError(f"turbulence min_speed_mps must be > 0, got {min_speed_mps!r}")
        if not (math.isfinite(min_height_m) and min_height_m > 0.0):
            raise ValueError(f"turbulence min_height_m must be > 0, got {min_height_m!r}")
        if memory is None:
            memory = np.zeros(DRYDEN_SIZE)
        if memory.shape != (DRYDEN_SIZE,) or memory.dtype != np.float64 or not memory.flags.c_contiguous:
            raise ValueError(f"DrydenTurbulence memory: expected {DRYDEN_SIZE} contiguous float64 slots")
        self.w20_mps = float(w20_mps)
        self.seed = seed
        self.mean_wind = mean_wind
        self.min_speed_mps = float(min_speed_mps)
        self.min_height_m = float(min_height_m)
        self.memory = memory
        self._mean_fn = mean_wind.mean if mean_wind is not None else None
        self.reset()

    def copy_into(self, memory: np.ndarray) -> DrydenTurbulence:
        """A fresh copy of this turbulence (the same configuration and seed, not yet sampled) living in ``memory``."""
        return DrydenTurbulence(
            self.w20_mps, seed=self.seed, mean_wind=self.mean_wind, min_speed_mps=self.min_speed_mps,
            min_height_m=self.min_height_m, memory=memory,
        )  # fmt: skip

    def reset(self) -> None:
        """Back to the initial seeded state: the next sample() restarts the series."""
        self.memory[:] = 0.0
        d = self.memory.view(DRYDEN)[0]
        d.min_speed_mps, d.hmin_ft, d.sigma_w_mps = self.min_speed_mps, self.min_height_m / FT_M, 0.1 * self.w20_mps
        self._rng = np.random.default_rng(self.seed)
        self.pool: np.ndarray = self._rng.standard_normal(POOL_NORMALS)
        """The noise :func:`dryden_sample` draws from (a new array after :meth:`refill`)."""

    def refill(self) -> None:
        """The next block of :data:`POOL_NORMALS` normals after the unused rest of the pool (a new array)."""
        d = self.memory.view(DRYDEN)[0]
        self.pool = np.concatenate((self.pool[int(d.pool_index) :], self._rng.standard_normal(POOL_NORMALS)))
        d.pool_index = 0.0

    def scales(self, up_m: float) -> tuple[float, float, float, float]:
        """(L_u = L_v in m, L_w in m, sigma_u = sigma_v in m/s, sigma_w in m/s) at ``up_m`` AGL."""
        return dryden_scales(up_m, self.w20_mps, self.min_height_m)

    def mean(self, up_m: float) -> Vec3:
        return (0.0, 0.0, 0.0)

    def sample(self, t_s: float, east_m: float, north_m: float, up_m: float, airspeed_mps: float) -> Vec3:
        me, mn, _ = self._mean_fn(up_m) if self._mean_fn is not None else ZERO
        e, n, u, low = dryden_sample(self.memory, self.pool, t_s, up_m, airspeed_mps, me, mn)
        if low:
            self.refill()
        return (e, n, u)

    def __repr__(self) -> str:
        return f"DrydenTurbulence(w20_mps={self.w20_mps!r}, seed={self.seed!r}, mean_wind={self.mean_wind!r})"
