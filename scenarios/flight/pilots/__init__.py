"""Pilots: what feeds outer-loop sticks to the aircraft (and, later, through the geofence).

* :class:`~scenarios.flight.pilots.mission.MissionAutopilot`: GPS waypoint autopilot.
* :class:`~scenarios.flight.pilots.scripted.ScriptedPilot`: adversarial stick scripts.
* :class:`~scenarios.flight.pilots.breach_attempts.BreachAttemptsPilot`: repeated gentle
  breach attempts (the seed flights' indoor pilot), and for a fixed-wing
  :class:`~scenarios.flight.pilots.breach_attempts_fixedwing.FixedWingBreachAttemptsPilot`
  (the same attempts from an orbit).

All answer ``command(state) -> StickCommand`` and report progress as
``items_reached`` / ``items_total`` and ``finished``. A pilot whose law has a compiled form
(:class:`CompiledLawPilot`: the scripted pilot) also splits a step into its decisions (``decide``) and its law's
array (``law_array``, :mod:`scenarios.flight.pilots.law_kernel`), which the compiled step of the closed loop
flies.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from geofence.geometry.geodesy import LocalFrame
from geofence.interface import Envelope, StickCommand, VehicleState
from scenarios.definition.schema import PilotKind, Scenario


class Pilot(Protocol):
    finished: bool

    @property
    def items_reached(self) -> int: ...

    @property
    def items_total(self) -> int: ...

    def command(self, state: VehicleState) -> StickCommand: ...

    def notice_control(self, in_control: bool) -> None:
        """Whether the pilot's sticks fly the aircraft this step (False while the geofence overrides them)."""


@runtime_checkable
class CompiledLawPilot(Protocol):
    """A pilot whose law has a compiled form: ``decide(state)`` takes a step's decisions and returns the sticks
    where its law has no compiled form this step, else None (``law_array()`` then flies the step, the same
    sticks ``command`` returns)."""

    def decide(self, state: VehicleState) -> StickCommand | None: ...

    def law_array(self) -> np.ndarray: ...


def build_pilot(scenario: Scenario, frame: LocalFrame, env: Envelope, start: VehicleState, dt_s: float) -> Pilot:
    """The pilot a scenario asks for, ready to fly from ``start``."""
    from scenarios.flight.pilots.mission import MissionAutopilot
    from scenarios.flight.pilots.scripted import ScriptedPilot

    if scenario.pilot.kind is PilotKind.SCRIPTED:
        return ScriptedPilot(scenario.pilot.segments, env, start, dt_s, frame)
    if scenario.pilot.kind is PilotKind.BREACH_ATTEMPTS:
        assert scenario.pilot.breach is not None, "the schema gives a breach_attempts pilot its settings"
        if not env.is_multirotor:
            from scenarios.flight.pilots.breach_attempts_fixedwing import FixedWingBreachAttemptsPilot

            return FixedWingBreachAttemptsPilot(scenario.pilot.breach, env, start, dt_s)
        from scenarios.flight.pilots.breach_attempts import BreachAttemptsPilot

        return BreachAttemptsPilot(scenario.pilot.breach, env, start, dt_s)
    assert scenario.mission is not None, "the schema requires a mission for the mission pilot"
    return MissionAutopilot(scenario.mission, frame, env, start, dt_s)
