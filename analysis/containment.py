"""Containment in the terms a SORA assessment uses: the volumes, each flight's exits of them, rates per class.

This module owns the sizing of the **contingency volume** and the **ground risk buffer** around the operational
volume (the fence: the flight geography with its ceiling), and the count of flights leaving each of them, per
failure class, with exact bounds. Numbers in, numbers and a figure out: the platform figures come from the
caller (:class:`ContingencyInputs`, e.g. built from a profile by the application), the flights from a campaign's
joined rows (:func:`analysis.campaign_report.campaign_rows`).

Sizing (the method of the LBA / EASA SORA guidance on flight geography and contingency volume, also used by the
Swiss FOCA; JARUS SORA Annex E), with ``v0`` the platform's top speed, ``t_R`` its reaction time, ``phi`` its
bank (fixed-wing) or tilt (multirotor) limit::

    S_CV = S_GNSS + S_pos + S_map + S_R + S_CM      S_R = v0 t_R        S_CM = v0^2 / (2 g tan phi)
    H_CV = H_baro + H_R + H_CM                       H_R = 0.707 v0 t_R  H_CM = v0^2 / (2 g)
    S_GRB = H_top (the 1:1 rule: the buffer as wide as the contingency volume's top above ground)

``S_CM`` is the stopping distance of a multirotor braking at its tilt limit and half the turn radius of a
fixed-wing at its bank limit; ``H_CM`` the height of trading the speed for height. A flight **exits** a volume
when its peak lateral excursion beyond the fence exceeds the volume's lateral extent (``S_CV``; ``S_CV + S_GRB``
for the buffer) or its peak excursion above the ceiling exceeds ``H_CV`` (``H_CV`` for the buffer too: the 1:1
rule is lateral). The volumes are the method's: laterally round the flight geography and above its top. A fence's
floor is the project's own restriction inside the flight geography (its gaps the only places to land): a flight
that went below it outside a gap stayed over the ground the operation was assessed for, so it is no volume's exit;
it is counted per class in a column of its own, never dropped. Rates: exits per flight with the one-sided exact (Clopper-Pearson) 95 % bound and exits per simulated
flight hour with the Poisson bound, per class (:func:`failure_class`): none is dropped, nominal and each single
failure side by side.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from analysis.batch_plots import num, save_figure, truthy
from analysis.bounds import clopper_pearson_upper, poisson_rate_upper
from geofence.interface import PlatformKind
from geofence.physics.dynamics import G_MPS2

VOLUMES = ("fence", "contingency volume", "ground risk buffer", "below a floor outside its gaps")


class ContingencyInputs(NamedTuple):
    """One platform's figures for the sizing (SI; the error terms default to the guidance's worked example)."""

    kind: PlatformKind
    v0_mps: float
    """Top speed (the envelope's max speed)."""
    reaction_time_s: float
    limit_rad: float
    """Bank limit (fixed-wing) or tilt limit (multirotor)."""
    gnss_error_m: float = 3.0
    position_hold_error_m: float = 3.0
    map_error_m: float = 1.0
    altitude_error_m: float = 1.0


class Contingency(NamedTuple):
    """The volumes' sizes (m): lateral ``s_cv_m`` and vertical ``h_cv_m`` beyond the fence, buffer ``s_grb_m``."""

    s_cv_m: float
    h_cv_m: float
    s_grb_m: float


def contingency_volume(p: ContingencyInputs, ceiling_agl_m: float) -> Contingency:
    """The contingency volume and the 1:1 ground risk buffer of a platform under a ceiling ``ceiling_agl_m``."""
    s_cm = p.v0_mps**2 / (2.0 * G_MPS2 * math.tan(p.limit_rad))
    s_cv = p.gnss_error_m + p.position_hold_error_m + p.map_error_m + p.v0_mps * p.reaction_time_s + s_cm
    h_cv = p.altitude_error_m + 0.707 * p.v0_mps * p.reaction_time_s + p.v0_mps**2 / (2.0 * G_MPS2)
    return Contingency(s_cv_m=s_cv, h_cv_m=h_cv, s_grb_m=ceiling_agl_m + h_cv)


def failure_class(row: Mapping) -> str:
    """The flight's class: its injected fault kinds (``fault: gnss_loss``), else its campaign condition."""
    faults = str(row.get("faults") or "").strip()
    return f"fault: {faults}" if faults else str(row.get("condition") or "nominal")


class Exits(NamedTuple):
    """Which volumes one flight left (fence, contingency volume, ground risk buffer), and its depth in ``S_CV``."""

    fence: bool
    contingency: bool
    buffer: bool
    floor: bool
    """Below a floor outside its gaps (in flight or on the ground): no volume's exit, counted on its own."""
    lateral_in_cv: float
    """Peak lateral excursion over ``S_CV`` (> 1: beyond the contingency volume; < 0: stayed inside the fence)."""


def flight_exits(row: Mapping, cv: Contingency) -> Exits:
    lat, ver = num(row.get("max_lateral_excursion_m")), num(row.get("max_vertical_excursion_m"))
    up = num(row.get("max_ceiling_excursion_m"))
    up = ver if not math.isfinite(up) else up  # (results scored before the field: the vertical excursion, either way)
    fence = lat > 0.0 or ver > 0.0 or truthy(row.get("breached_keep_out")) or truthy(row.get("landed_outside_gap"))
    return Exits(
        fence=fence,
        contingency=lat > cv.s_cv_m or up > cv.h_cv_m,
        buffer=lat > cv.s_cv_m + cv.s_grb_m or up > cv.h_cv_m,
        # a touchdown outside every gap is the floor's only inside the fence: outside it, it is the fence's exit
        floor=(truthy(row.get("landed_outside_gap")) and not lat > 0.0) or (ver > 0.0 and ver > up),
        lateral_in_cv=lat / cv.s_cv_m,
    )


def row_contingency(row: Mapping, inputs: Mapping[str, ContingencyInputs]) -> Contingency | None:
    """The volumes of the row's platform under its case's ceiling (None: a platform without figures)."""
    p = inputs.get(str(row.get("platform") or row.get("aircraft")))
    ceiling = num(row.get("ceiling_m"))
    return None if p is None else contingency_volume(p, ceiling if math.isfinite(ceiling) else 0.0)


class ClassRates(NamedTuple):
    name: str
    flights: int
    hours: float
    exits: tuple[int, int, int, int]
    """Flights leaving the fence, the contingency volume, the ground risk buffer; flights below a floor outside
    its gaps."""


def class_rates(rows: Sequence[Mapping], inputs: Mapping[str, ContingencyInputs]) -> list[ClassRates]:
    """Per class, the scored flights with figures, their simulated hours and each volume's exits."""
    by: dict[str, list] = {}
    for r in rows:
        cv = row_contingency(r, inputs)
        if cv is None or r.get("error") or not math.isfinite(num(r.get("max_excursion_m"))):
            continue
        by.setdefault(failure_class(r), []).append((r, flight_exits(r, cv)))
    out = []
    for name in sorted(by, key=lambda n: (n != "nominal", n)):
        sel = by[name]
        hours = sum(max(num(r.get("sim_time_s")), 0.0) for r, _ in sel if math.isfinite(num(r.get("sim_time_s")))) / 3600
        fence, cv, grb, floor = (sum(getattr(e, f) for _, e in sel) for f in ("fence", "contingency", "buffer", "floor"))
        out.append(ClassRates(name, len(sel), hours, (fence, cv, grb, floor)))
    return out


def containment_lines(rows: Sequence[Mapping], inputs: Mapping[str, ContingencyInputs]) -> list[str]:
    """The report's containment section (markdown) for one variant's rows."""
    lines = [
        "| platform | v0 (m/s) | t_R (s) | limit (deg) | S_CV (m) | H_CV (m) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    flown = {str(r.get("platform") or r.get("aircraft")) for r in rows}
    for name, p in sorted(inputs.items()):
        if name not in flown:
            continue
        cv = contingency_volume(p, 0.0)
        lines.append(f"| {name} | {p.v0_mps:.1f} | {p.reaction_time_s:.2f} | {math.degrees(p.limit_rad):.0f} | "
                     f"{cv.s_cv_m:.1f} | {cv.h_cv_m:.1f} |")  # fmt: skip
    return lines + [""] + class_rate_lines(class_rates(rows, inputs))


def class_rate_lines(classes: Sequence[ClassRates]) -> list[str]:
    """The containment table (markdown): per class its flights, flight hours and each volume's exits, per flight
    with the exact 95 % bound and per flight hour with the Poisson 95 % bound."""
    lines = ["| class | flights | flight h | " + " | ".join(f"{v}: exits, per flight (95 % ≤), per h (95 % ≤)" for v in VOLUMES) + " |",
             "|---|---:|---:|" + "---|" * len(VOLUMES)]  # fmt: skip
    for c in classes:
        cells = []
        for k in c.exits:
            per_h = poisson_rate_upper(k, c.hours)
            cells.append(f"{k}, {k / c.flights:.3g} ({clopper_pearson_upper(k, c.flights):.2g}), "
                         f"{k / c.hours if c.hours else math.nan:.3g} ({per_h:.2g})")  # fmt: skip
        lines.append(f"| {c.name} | {c.flights} | {c.hours:.1f} | " + " | ".join(cells) + " |")
    return lines


def class_rates_record(classes: Sequence[ClassRates]) -> list[dict]:
    """The classes as plain records (``name``, ``flights``, ``hours``, ``exits`` by volume) for a counts file."""
    return [{"name": c.name, "flights": c.flights, "hours": c.hours, "exits": dict(zip(VOLUMES, c.exits))} for c in classes]


def add_class_rates(shards: Sequence[Sequence[ClassRates]]) -> list[ClassRates]:
    """The classes of several shards of one campaign added up by name (flights, hours and exits are counts over
    disjoint flights: their sums are the whole campaign's), nominal first."""
    total: dict[str, list] = {}
    for classes in shards:
        for c in classes:
            t = total.setdefault(c.name, [0, 0.0, [0] * len(VOLUMES)])
            t[0] += c.flights
            t[1] += c.hours
            t[2] = [a + b for a, b in zip(t[2], c.exits)]
    return [
        ClassRates(name, t[0], t[1], (t[2][0], t[2][1], t[2][2], t[2][3]))
        for name, t in sorted(total.items(), key=lambda kv: (kv[0] != "nominal", kv[0]))
    ]


def plot_containment(rows: Sequence[Mapping], inputs: Mapping[str, ContingencyInputs], out_base: Path) -> list[Path]:
    """Each flight's peak lateral excursion in contingency-volume widths, per class: 0 is the fence, 1 the
    contingency volume's outer edge."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by: dict[str, list[float]] = {}
    for r in rows:
        cv = row_contingency(r, inputs)
        if cv is not None and not r.get("error") and math.isfinite(num(r.get("max_lateral_excursion_m"))):
            by.setdefault(failure_class(r), []).append(flight_exits(r, cv).lateral_in_cv)
    names = sorted(by, key=lambda n: (n != "nominal", n))
    fig, ax = plt.subplots(figsize=(8.5, 2.4 + 0.5 * max(len(names), 1)))
    rng = np.random.default_rng(0)
    for i, n in enumerate(names):
        x = np.clip(np.asarray(by[n]), -3.0, None)
        ax.scatter(x, i + rng.uniform(-0.18, 0.18, len(x)), s=12, alpha=0.6, edgecolors="none", color="tab:blue")
    for x, label, colour, ha in ((0.0, "fence ", "tab:orange", "right"), (1.0, " contingency volume", "tab:red", "left")):
        ax.axvline(x, color=colour, lw=1.2, ls="--")
        ax.text(x, 1.01, label, color=colour, va="bottom", ha=ha, transform=ax.get_xaxis_transform())
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels([f"{n} ({len(by[n])})" for n in names])
    ax.set_ylim(-0.6, len(names) - 0.4)
    ax.set_xlabel("peak lateral excursion beyond the fence / S_CV (< 0: inside; clipped at -3)")
    ax.set_title("Peak excursions against the contingency volume, per class (predictive)", pad=22)
    ax.grid(axis="x", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out_base)
