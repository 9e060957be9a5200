"""The closed loop: fly one scenario and write its trajectory and summary.

Per outer-loop step (``control_rate_hz``, default 40 Hz; JSBSim runs its own
frames in between, with the flight controller inside JSBSim):

    truth  = platform.truth()
    wind   = wind_field.sample(t, position, airspeed) -> platform.set_wind_enu
    cmd_in = pilot.command(truth)
    cmd, mode = geofence.filter(...) if a geofence is configured, else cmd_in
    platform.command(cmd); recorder.append(...); platform.step(frames_per_step)

While a predictive unit monitors (and while a fixed-wing override flies), the
wind sample, the unit's sensing and monitoring step and the recorder's row are one call
(:class:`scenarios.flight.step_kernel.FlightStep`: compiled, or the same functions interpreted
without numba); a step the unit answers itself is :func:`scenarios.flight.step_kernel.unit_step`.

The run stops at ``duration_s`` or two seconds after the pilot finished its
mission. Files: ``<out>/<scenario>/trajectory.csv`` and ``summary.json`` (see
:func:`write_result`: the folder is replaced as a whole).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from aircraft.factory import build_platform
from analysis.scoring import SCORED_COLUMNS, score_flight, sustained_wind_peak_mps
from geofence.geometry.geodesy import LocalFrame
from geofence.geometry.local_fence import LocalFence
from geofence.interface import Envelope, StickCommand
from geofence.unit.geofence_unit import GeofenceUnit, Mode
from scenarios.definition.faults import FC_KINDS, Fault, FaultKind
from scenarios.definition.preflight import findings_summary, preflight_findings
from scenarios.definition.schema import PilotKind, Scenario
from scenarios.flight.pilots import CompiledLawPilot, Pilot, build_pilot
from scenarios.flight.recorder import COLUMN_INDEX, Recorder
from scenarios.flight.sensing import GeofenceSensing
from scenarios.flight.step_kernel import NOT_FOLLOWING, WATCHED, FlightStep, unit_step
from wind.config import wind_from_config
from wind.field import CalmWind, WindField, notify_first_activation
from wind.field_kernel import WindArrays, compiled_wind

TAIL_AFTER_FINISH_S = 2.0


@dataclass
class FlightResult:
    """A flown scenario: its summary and arrays, and the objects that flew it (for experiments to read).

    ``pilot``: the pilot the runner built (e.g. its ``attempt_log``); ``unit`` and
    ``fence``: the geofence unit and its local fence (None without a geofence).
    """

    scenario: Scenario
    summary: dict[str, Any]
    recorder: Recorder
    frame: LocalFrame
    pilot: Pilot
    unit: GeofenceUnit | None = None
    fence: LocalFence | None = None
    compiled_steps: int = 0
    """Steps whose wind, sensing, unit and row were one compiled call (:mod:`scenarios.flight.step_kernel`)."""


def fly(scenario: Scenario, on_step: Callable[[float], None] | None = None) -> FlightResult:
    """Fly ``scenario`` in closed loop and return the recorded flight (nothing is written)."""
    wall0 = time.perf_counter()
    setup = set_up_flight(scenario)
    frame, platform, env, wind, wind_arrays = setup.frame, setup.platform, setup.env, setup.wind, setup.wind_arrays
    sampler, sample_wind, frames_per_step, dt_s = setup.sampler, setup.sample_wind, setup.frames_per_step, setup.dt_s
    n_steps, recorder, t0, pilot = setup.n_steps, setup.recorder, setup.t0, setup.pilot
    fence: LocalFence | None = None
    unit: GeofenceUnit | None = None
    own: GeofenceSensing | None = None
    if scenario.geofence is not None:
        fence = scenario.geofence.fence.to_local(frame)
        unit = GeofenceUnit(scenario.geofence, fence, env)
        own = GeofenceSensing(scenario, scenario.geofence, frame, env)

    error = None
    wind_told = False
    finished_at = None
    mode = Mode.MONITOR
    monitor, recovered, land_in_gap = Mode.MONITOR, Mode.RECOVERED, Mode.LAND_IN_GAP
    terminate = Mode.TERMINATE
    terminated: float | None = None  # when the runner cut the propulsion (Platform.terminate)
    struck = False  # the terminated vehicle struck the ground (the flight ended there)
    step = 0
    # faster than this is a numerical blow-up (e.g. a ground-contact explosion), not flight
    diverged_above_mps = 5.0 * env.max_speed_mps + 50.0
    # the per-step calls, bound once (a method lookup per call and step is measurable at this rate)
    truth_now, set_wind, latch, advance = platform.truth, platform.set_wind_enu, platform.command, platform.step
    pilot_sticks, notice_control, record = pilot.command, pilot.notice_control, recorder.append
    # while the unit monitors, a step's wind, sensing, unit and row in one compiled call (the same numbers), and the
    # pilot's law where it has a compiled form (then its decisions alone before the call)
    law_pilot = pilot if isinstance(pilot, CompiledLawPilot) else None
    pilot_decide = pilot_sticks if law_pilot is None else law_pilot.decide
    fused = FlightStep.build(
        unit, own, wind_arrays, isinstance(wind, CalmWind), recorder, dt_s,
        None if law_pilot is None else law_pilot.law_array(),
    )  # fmt: skip
    faults = FlightFaults(scenario.faults, platform, recorder, own) if scenario.faults else None
    loop0 = time.perf_counter()
    try:
        for step in range(n_steps + 1):
            truth = truth_now()
            t = truth.t_s = truth.t_s - t0
            if abs(truth.v_east_mps) + abs(truth.v_north_mps) + abs(truth.v_up_mps) > diverged_above_mps:
                raise FloatingPointError(
                    f"JSBSim state of {scenario.aircraft} diverged (speed beyond {diverged_above_mps:.0f} m/s) at t={t:.2f} s"
                )
            watched = 0  # (the compliance watch's flags where the compiled call watched the step)
            if fused is not None and fused.ready:
                w, cmd = fused.step(truth, t, pilot_decide(truth), pilot.items_reached)  # (its row recorded)
                set_wind(*w)
                watched = fused.watched
            else:
                w = sample_wind(t, truth.east_m, truth.north_m, truth.agl_m, truth.airspeed_mps)
                set_wind(*w)
                cmd_in = pilot_sticks(truth)
                if unit is not None and own is not None:
                    sensed = own.sense(truth, dt_s)
                    if fused is not None:  # (then asked whether the next step can be its compiled call)
                        cmd = fused.by_unit(truth, t, w, cmd_in, pilot.items_reached, sensed)
                    else:
                        cmd = unit_step(unit, recorder, truth, t, w, cmd_in, pilot.items_reached, sensed, dt_s)
                else:
                    cmd = cmd_in
                    record(truth, w, cmd_in, cmd, mode, pilot.items_reached)
            if unit is not None:
                # the compliance watch on what the unit sent (its sticks or the pilot's), unless the compiled call
                # watched the step and found the vehicle following
                if watched != WATCHED and unit.watching and watch_compliance(unit, fused, watched, t, dt_s, cmd):
                    if fused is not None:  # (switched to TERMINATE)
                        fused.finish()  # (the steps it took handed over before the unit answers again)
                        fused.refresh()
                mode = unit.mode
                notice_control(mode == monitor or mode == recovered)  # the pilot feels the sticks come back
                if not wind_told and unit.activations:
                    notify_first_activation(sampler, t)  # gusts timed from the first override
                    if fused is not None:
                        fused.wind_changed()
                    wind_told = True
            if faults is not None:  # (between the unit's sticks and the platform; the unit is not told)
                cmd = faults.apply(t, cmd, None if unit is None else unit.first_activation_s)
            latch(cmd)
            if mode == terminate and terminated is None and unit is not None and unit.termination is not None:
                # a vehicle not following the override: the termination channel, after the sticks, whatever they
                # are (the landing's own low termination over a gap spirals down on the sticks, as before)
                platform.terminate()
                terminated = t
            # landed in a gap / terminated; a terminated vehicle's impact ends the flight at the last step above
            # the ground (at 20+ m/s the model's gear would bounce it back up and diverge within the next step)
            impact = terminated is not None and truth.agl_m <= max(IMPACT_AGL_M, -truth.v_up_mps * dt_s)
            struck = struck or impact
            ended_by_geofence = mode >= land_in_gap and (truth.on_ground or impact)
            if finished_at is None and (pilot.finished or ended_by_geofence):
                finished_at = t
            if finished_at is not None and t - finished_at >= (0.0 if ended_by_geofence else TAIL_AFTER_FINISH_S):
                break  # (after a touchdown in a gap: at once)
            if step == n_steps:
                break
            advance(frames_per_step)
            if on_step is not None:
                on_step(dt_s)
    except FloatingPointError as exc:
        error = str(exc)
    if fused is not None:
        fused.finish()  # the unit takes in the steps the compiled call let through

    loop_wall = time.perf_counter() - loop0
    wall = time.perf_counter() - wall0
    frames = step * frames_per_step
    mission = scenario.pilot.kind is PilotKind.MISSION
    geofence_ended = unit is not None and unit.mode >= Mode.LAND_IN_GAP and finished_at is not None
    # a flight is complete when it ran to its end: the mission finished, a script ran its
    # duration, or the geofence ended it by landing in a floor gap / terminating there
    completed = error is None and (pilot.finished or geofence_ended if mission else True)
    summary = flight_summary(scenario, env, pilot, recorder, completed, geofence_ended, error, wall, loop_wall, frames, dt_s)
    if unit is not None and fence is not None:
        summary["preflight"] = findings_summary(preflight_findings(scenario, fence))
        traj = {name: recorder.column(name) for name in SCORED_COLUMNS}
        summary.update(score_flight(traj, fence))
        summary["activations"] = unit.activations
        first = unit.first_activation_s
        summary["first_activation_s"] = None if first is None else round(first, 3)  # as the transitions' times
        summary["final_mode"] = unit.mode.name
        summary["mode_transitions"] = [tr.as_dict() for tr in unit.transitions]
    if unit is not None and fence is not None and terminated is not None:
        summary.update(termination_summary(unit, fence, terminated, truth_now(), struck))
    if faults is not None:
        summary["faults"] = faults.summary()
    return FlightResult(
        scenario=scenario, summary=summary, recorder=recorder, frame=frame, pilot=pilot, unit=unit, fence=fence,
        compiled_steps=0 if fused is None else fused.steps,
    )  # fmt: skip


def watch_compliance(
    unit: GeofenceUnit, fused: FlightStep | None, watched: int, t_s: float, dt_s: float, cmd: StickCommand
) -> bool:  # fmt: skip
    """A step's compliance watch: the unit's own (:meth:`GeofenceUnit.watch_compliance`) where the compiled call did
    not watch the step (``watched`` 0), else its finding that the vehicle does not follow
    (:data:`~scenarios.flight.step_kernel.NOT_FOLLOWING`) decided by the unit (:meth:`GeofenceUnit.not_following`),
    on the unit's newest estimate. Returns whether the unit switched to ``TERMINATE``."""
    est = unit.estimate if fused is None else fused.newest_estimate()
    if est is None:
        return False
    if watched == 0:
        return unit.watch_compliance(t_s, dt_s, cmd, est)
    return bool(watched & NOT_FOLLOWING) and unit.not_following(t_s, dt_s, est)


class FlightFaults:
    """A flight's faults as the runner applies them (see :mod:`scenarios.definition.faults`): the flight
    controller's between the unit's sticks and the platform (ignoring an override: the platform gets the pilot's
    sticks, recorded in the step's row; freezing: the last sticks it got before), the loss of propulsion (once, at
    its onset, :meth:`aircraft.fixedwing.FixedWingPlatform.cut_propulsion`), and the timing of those that start
    at the unit's first activation (the sensors' too: :meth:`aircraft.sensors.SensorSuite.trigger_faults`)."""

    def __init__(self, faults: tuple[Fault, ...], platform: Any, recorder: Recorder, sensing: GeofenceSensing | None):
        self.faults = faults
        self.platform = platform
        self.recorder = recorder
        self.sensing = sensing
        self.onsets: list[float | None] = [None] * len(faults)
        """Each fault's onset time once it started (None: not yet, or never)."""
        self.first_activation_s: float | None = None
        self._last: StickCommand = StickCommand()
        self._pilot = slice(COLUMN_INDEX["pilot_roll"], COLUMN_INDEX["pilot_throttle"] + 1)

    def apply(self, t_s: float, cmd: StickCommand, first_activation_s: float | None) -> StickCommand:
        """The sticks the platform gets at ``t_s`` for the unit's ``cmd`` (after the step's row is recorded)."""
        if first_activation_s is not None and self.first_activation_s is None:
            self.first_activation_s = first_activation_s
            if self.sensing is not None and self.sensing.compiled:
                self.sensing.sensors.trigger_faults(first_activation_s)
        sent, frozen = cmd, False
        for i, f in enumerate(self.faults):
            if self.onsets[i] is None:
                onset = f.onset_s(self.first_activation_s)
                if onset is None or t_s < onset:
                    continue
                self.onsets[i] = onset
                if f.kind is FaultKind.PROPULSION_LOSS:
                    self.platform.cut_propulsion()
            if f.kind not in FC_KINDS or not f.active(t_s, self.first_activation_s):
                continue
            if f.kind is FaultKind.FC_FREEZES:
                sent, frozen = self._last, True
            elif not frozen:
                T, n = self.recorder.next_row()
                sent = StickCommand(*T[n - 1, self._pilot].tolist())
        self._last = sent
        return sent

    def summary(self) -> list[dict[str, Any]]:
        """``[{kind, onset_s}]``: each fault and when it started (None: it never did)."""
        return [
            {"kind": f.kind.value, "onset_s": None if onset is None else round(onset, 3)}
            for f, onset in zip(self.faults, self.onsets)
        ]


def termination_summary(
    unit: GeofenceUnit, fence: LocalFence, terminated_s: float, last: Any, struck: bool = False
) -> dict[str, Any]:
    """A terminated flight's keys: when and why the propulsion was cut (``terminated_at_s``, ``termination_reason``),
    the unit's compliance finding and footprint (``termination``: None for a termination low over a gap), and
    where it came down (``touchdown_en_m``, and ``touchdown_margin_m``: the fence's lateral margin there, below a
    floor the least of it and the floor gaps' distance; + inside), or None if it had not touched down (``struck``:
    the flight ended at its impact, the last step above the ground)."""
    reason = next((tr.reason for tr in reversed(unit.transitions) if tr.to_mode is Mode.TERMINATE), None)
    out: dict[str, Any] = {
        "terminated_at_s": round(terminated_s, 3), "termination_reason": reason, "termination": unit.termination,
        "touchdown_en_m": None, "touchdown_margin_m": None,
    }  # fmt: skip
    if last is not None and (last.on_ground or struck):
        e, n = last.east_m, last.north_m
        margin = fence.lateral_margin_m(e, n)
        if fence.floor_m is not None:
            margin = min(margin, fence.gap_distance_m(e, n))
        out["touchdown_en_m"] = [round(e, 2), round(n, 2)]
        out["touchdown_margin_m"] = round(margin, 2)
    return out


IMPACT_AGL_M = 0.3
"""A terminated vehicle this close to the ground (or closer than one step of its descent) has struck it."""


@dataclass
class FlightSetup:
    """What a flight is flown with before its first step: the platform reset at the start, settled in the wind at
    t = 0, the wind (its field, its compiled arrays where it has them, the sampler), the step, the recorder and
    the pilot (:func:`set_up_flight`)."""

    frame: LocalFrame
    platform: Any
    env: Envelope
    wind: WindField
    wind_arrays: WindArrays | None
    sampler: WindField | WindArrays
    sample_wind: Callable[..., Any]
    frames_per_step: int
    dt_s: float
    n_steps: int
    recorder: Recorder
    t0: float
    pilot: Pilot


def set_up_flight(scenario: Scenario) -> FlightSetup:
    """The platform, wind, recorder and pilot of ``scenario``, the platform reset at its start (for :func:`fly` and
    the MAVLink vehicle, :mod:`scenarios.flight.mavlink_vehicle`)."""
    st = scenario.start
    frame = scenario.frame
    platform = build_platform(scenario.profile)
    env = platform.envelope
    wind = wind_from_config(scenario.wind, scenario.seed) if scenario.wind is not None else CalmWind()
    # the wind's arrays sampled by one compiled call (the same numbers), where the field is one wind_from_config
    # builds; else the field objects
    wind_arrays = compiled_wind(wind)
    sampler: WindField | WindArrays = wind if wind_arrays is None else wind_arrays  # sample() and the activation hook
    sample_wind = sampler.sample
    # the start is settled in the wind at t = 0 (platforms keep a wind set before reset)
    platform.set_wind_enu(*sample_wind(0.0, 0.0, 0.0, st.agl_m, st.airspeed_mps or env.cruise_speed_mps))
    platform.reset(frame, st.lat_deg, st.lon_deg, st.agl_m, st.heading_deg, st.airspeed_mps)

    frames_per_step = scenario.frames_per_step  # (the platform's dt_s is 1 / profile.frame_rate_hz)
    dt_s = frames_per_step * platform.dt_s
    n_steps = int(math.ceil(scenario.duration_s / dt_s))
    recorder = Recorder(n_steps + 1)

    truth = platform.truth()
    t0 = truth.t_s
    pilot = build_pilot(scenario, frame, env, truth, dt_s)
    return FlightSetup(
        frame, platform, env, wind, wind_arrays, sampler, sample_wind, frames_per_step, dt_s, n_steps, recorder, t0, pilot
    )


def flight_summary(
    scenario: Scenario, env: Envelope, pilot: Pilot, recorder: Recorder, completed: bool, geofence_ended: bool,
    error: str | None, wall: float, loop_wall: float, frames: int, dt_s: float,
) -> dict[str, Any]:  # fmt: skip
    """The summary keys every flight has (the geofence's scores and transitions are added by the caller)."""
    return {
        "scenario": scenario.name,
        "aircraft": scenario.aircraft,
        "platform_kind": env.kind.value,
        "pilot": scenario.pilot.kind,
        "seed": scenario.seed,
        "wind_speed_mps": scenario.wind.speed_mps if scenario.wind is not None else 0.0,
        "wind_from_deg": scenario.wind.from_deg if scenario.wind is not None else None,
        "geofence": scenario.geofence is not None,
        "completed": completed,
        "mission_finished": bool(pilot.finished),
        "ended_by_geofence": bool(geofence_ended),
        "mission_progress": f"{pilot.items_reached}/{pilot.items_total}",
        "waypoints_reached": pilot.items_reached,
        "waypoints_total": pilot.items_total,
        "sim_time_s": round(float(recorder.column("time_s")[-1]) if recorder.n else 0.0, 3),
        "wall_time_s": round(wall, 3),
        "control_rate_hz": round(1.0 / dt_s, 3),
        "jsbsim_frames": frames,
        "jsbsim_frames_per_wall_s": round(frames / wall, 1) if wall > 0 else None,
        "loop_wall_time_s": round(loop_wall, 4),
        "max_agl_m": round(float(recorder.column("agl_m").max()), 2) if recorder.n else 0.0,
        "max_ground_speed_mps": round(float(recorder.column("ground_speed_mps").max()), 2) if recorder.n else 0.0,
        "peak_sustained_wind_mps": _rounded_or_none(
            sustained_wind_peak_mps(
                recorder.column("time_s"), recorder.column("wind_east_mps"), recorder.column("wind_north_mps")
            ),
            3,
        ),
        "error": error,
    }


def _rounded_or_none(x: float, digits: int) -> float | None:
    """``x`` rounded, or None where it is NaN (a flight of fewer than two steps)."""
    return None if math.isnan(x) else round(x, digits)


def write_result(
    result: FlightResult,
    out_dir: Path,
    folder_name: str | None = None,
    *,
    scenario_text: str | None = None,
    plot: bool = False,
    scenario_hash: str | None = None,
    trajectory: bool = True,
) -> Path:
    """Write a flight's folder ``out_dir/<folder_name or scenario name>/``, replacing any previous one as a whole.

    Everything (``scenario.yaml`` when ``scenario_text`` is given, ``trajectory.csv`` unless not ``trajectory``,
    ``flight.png``/``.svg`` when ``plot``, then ``summary.json``) is written into a
    temporary folder beside it, which is then swapped in: nothing of an earlier
    flight of the same name (a stale ``flight.png``, ``attempts.json``) survives,
    and a reader never sees a half-written folder. The summary gains
    ``scenario_hash`` (the flight's identity, see :func:`scenarios.definition.sweep.scenario_hash`;
    computed from ``scenario.source`` when not given), ``incomplete_reason`` and
    ``warnings`` (inconsistencies the scenario allowed).
    """
    finalize_summary(result, scenario_hash)

    def fill(folder: Path) -> None:
        if scenario_text is not None:
            (folder / "scenario.yaml").write_text(scenario_text)
        if trajectory:
            result.recorder.write_csv(folder / "trajectory.csv")
        if plot:
            from analysis.plots import plot_result

            plot_result(result, folder)
        (folder / "summary.json").write_text(json.dumps(_json_safe(result.summary), indent=2, allow_nan=False) + "\n")

    return replace_folder(Path(out_dir) / (folder_name or result.scenario.name), fill)


def replace_folder(final: Path, fill: Callable[[Path], None]) -> Path:
    """Let ``fill`` write a temporary folder beside ``final``, then swap it in for ``final`` (removing the old one)."""
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=STAGING_SUFFIX, dir=final.parent))
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(staging, 0o777 & ~umask)  # an ordinary folder, not mkdtemp's private 0700
        fill(staging)
        old = None
        if final.is_dir() and not final.is_symlink():
            old = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=STAGING_SUFFIX, dir=final.parent))
            os.replace(final, old / "previous")
        elif final.exists() or final.is_symlink():
            final.unlink()
        os.replace(staging, final)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return final


STAGING_SUFFIX = ".tmp"
"""Temporary flight folders are ``.<flight>.<random>.tmp`` beside the flight (removed, or swept at a batch's start)."""


def finalize_summary(result: FlightResult, scenario_hash: str | None = None) -> dict[str, Any]:
    """Add ``scenario_hash``, ``incomplete_reason`` and ``warnings`` to ``result.summary`` (in place); returns it."""
    s = result.summary
    sc = result.scenario
    if scenario_hash is None and "scenario_hash" not in s:
        scenario_hash = hash_of_source(sc)
    if scenario_hash is not None:
        s["scenario_hash"] = scenario_hash
    s["incomplete_reason"] = incomplete_reason(s, sc)
    if sc.warnings:
        s["warnings"] = list(sc.warnings)
    return s


def incomplete_reason(summary: dict[str, Any], scenario: Scenario) -> str | None:
    """Why a flight did not complete, in one sentence (``None`` if it completed)."""
    if summary.get("completed"):
        return None
    if summary.get("error"):
        return f"the simulation stopped: {summary['error']}"
    reason = "the flight did not run to its end"
    if scenario.pilot.kind is PilotKind.MISSION and not summary.get("mission_finished"):
        reason = (
            f"the mission was not finished within duration_s = {scenario.duration_s:g} s "
            f"(reached {summary.get('mission_progress', '?')} mission items)"
        )
    if summary.get("activations"):
        reason += f"; the geofence overrode the pilot {summary['activations']} time(s) (final mode {summary.get('final_mode')})"
    if scenario.warnings:
        reason += "; the scenario allows: " + ", ".join(sorted(scenario.allow))
    return reason


def hash_of_source(scenario: Scenario) -> str | None:
    """The identity of a scenario loaded from a (non-sweep) file, or None."""
    if scenario.source is None or not Path(scenario.source).is_file():
        return None
    from geofence.validation import ConfigError
    from scenarios.definition.schema import read_document
    from scenarios.definition.sweep import expand, with_referenced_files

    try:
        source = Path(scenario.source)
        specs = with_referenced_files(expand(read_document(source), str(source), source.stem), source.parent)
    except ConfigError:
        return None
    return specs[0].scenario_hash if len(specs) == 1 else None


def _json_safe(value):
    """Strict JSON: non-finite floats (e.g. NaN "no activation" scores) become null."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def run_scenario(
    scenario: Scenario,
    out_dir: Path,
    on_step: Callable[[float], None] | None = None,
    *,
    plot: bool = False,
    scenario_hash: str | None = None,
) -> FlightResult:
    """Fly a scenario and write its folder (see :func:`write_result`; ``scenario.yaml`` is a copy of its source file)."""
    result = fly(scenario, on_step=on_step)
    text = Path(scenario.source).read_text() if scenario.source is not None and Path(scenario.source).is_file() else None
    write_result(result, out_dir, scenario_text=text, plot=plot, scenario_hash=scenario_hash)
    return result
