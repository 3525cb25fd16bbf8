"""The deploy state machine, with the safety a person expects before powering a robot:

    passive (no torque) --start--> move to default (timed) --done--> hold --start--> policy
    any of them --stop / fault--> damping (kp 0, kd > 0); from damping only a restart of the process leaves

A start signal is the remote's start button, the keyboard (Enter) or `--autostart` (a hold of `autostart_hold_s`).
Faults, checked every control step: no state message for `max_state_age_s` (the link lost), a state whose tick has
not moved for `max_state_age_s` (a frozen stream), a fall (the IMU's tilt past `max_tilt_rad`, from hold on), a
joint past its limits by `joint_limit_margin_rad` (in the policy), a policy output that is not finite or lies past
the joint limits by `target_limit_margin_rad`. Every transition is kept with its cause and time."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from agile.deploy.policy import RobotState


class Mode(str, Enum):
    PASSIVE = "passive"
    MOVE_TO_DEFAULT = "move_to_default"
    HOLD = "hold"
    POLICY = "policy"
    DAMPING = "damping"


@dataclass(frozen=True)
class SafetyLimits:
    max_state_age_s: float = 0.06
    """3 control periods at 50 Hz."""
    max_tilt_rad: float = math.radians(45.0)
    joint_limit_margin_rad: float = 0.1
    target_limit_margin_rad: float = 1.0
    move_duration_s: float = 2.0
    autostart_hold_s: float = 1.0


@dataclass(frozen=True)
class Transition:
    time_s: float
    source: Mode
    target: Mode
    cause: str
    state_age_s: float | None
    """How old the newest state was at the transition (None before the first)."""


@dataclass
class SafetyStateMachine:
    limits: SafetyLimits
    lower_q: np.ndarray
    upper_q: np.ndarray
    autostart: bool = False
    on_transition: object = None
    """Called with each Transition (the command layer logs it)."""
    mode: Mode = Mode.PASSIVE
    entered_s: float = 0.0
    transitions: list = field(default_factory=list)
    fault: str | None = None
    """The cause of damping when it was a fault (None for a stop or before damping)."""
    _tick: int | None = None
    _tick_changed_s: float = 0.0

    def go(self, target: Mode, cause: str, now_s: float, state: RobotState | None) -> None:
        if self.mode is target or self.mode is Mode.DAMPING:
            return
        age = None if state is None else now_s - state.received_s
        transition = Transition(now_s, self.mode, target, cause, age)
        self.transitions.append(transition)
        self.mode, self.entered_s = target, now_s
        if self.on_transition is not None:
            self.on_transition(transition)

    def stop(self, cause: str, now_s: float, state: RobotState | None) -> None:
        self.go(Mode.DAMPING, cause, now_s, state)

    def damp_for_fault(self, cause: str, now_s: float, state: RobotState | None) -> None:
        if self.mode is not Mode.DAMPING:
            self.fault = cause
        self.stop(cause, now_s, state)

    def start(self, cause: str, now_s: float, state: RobotState | None) -> None:
        """A start signal: passive -> move to default, hold -> policy; ignored elsewhere and before a state."""
        if state is None:
            return
        if self.mode is Mode.PASSIVE:
            self.go(Mode.MOVE_TO_DEFAULT, cause, now_s, state)
        elif self.mode is Mode.HOLD:
            self.go(Mode.POLICY, cause, now_s, state)

    def check_state(self, now_s: float, state: RobotState | None, started_s: float) -> None:
        """The faults of the state itself; `started_s`: when the loop began (the first state is waited for)."""
        if state is None:
            if now_s - started_s > self.limits.max_state_age_s:
                self.damp_for_fault(f"no state message within {self.limits.max_state_age_s:.3f} s (link lost)",
                                    now_s, None)
            return
        age_s = now_s - state.received_s
        if age_s > self.limits.max_state_age_s:
            self.damp_for_fault(f"newest state {age_s:.3f} s old > {self.limits.max_state_age_s:.3f} s (link lost)",
                                now_s, state)
            return
        if state.tick != self._tick:
            self._tick, self._tick_changed_s = state.tick, state.received_s
        elif now_s - self._tick_changed_s > self.limits.max_state_age_s:
            self.damp_for_fault(f"state tick {state.tick} frozen for {now_s - self._tick_changed_s:.3f} s "
                                f"> {self.limits.max_state_age_s:.3f} s (frozen state stream)", now_s, state)
            return
        if self.mode in (Mode.HOLD, Mode.POLICY):
            tilt = math.acos(max(-1.0, min(1.0, -float(state.projected_gravity()[2]))))
            if tilt > self.limits.max_tilt_rad:
                self.damp_for_fault(f"tilt {math.degrees(tilt):.1f} deg > {math.degrees(self.limits.max_tilt_rad):.1f}"
                                    f" deg (a fall)", now_s, state)
                return
        if self.mode is Mode.POLICY:
            margin = self.limits.joint_limit_margin_rad
            past = np.flatnonzero((state.q < self.lower_q - margin) | (state.q > self.upper_q + margin))
            if past.size:
                i = int(past[0])
                self.damp_for_fault(f"joint {i} at {state.q[i]:.3f} rad, past its limits [{self.lower_q[i]:.3f}, "
                                    f"{self.upper_q[i]:.3f}] by more than {margin} rad", now_s, state)

    def check_targets(self, q_target: np.ndarray, now_s: float, state: RobotState) -> bool:
        """Whether the policy's targets may be written: finite and within the joint limits' margin; else damping."""
        if not np.all(np.isfinite(q_target)):
            self.damp_for_fault(f"policy output not finite at joints {np.flatnonzero(~np.isfinite(q_target)).tolist()}",
                                now_s, state)
            return False
        margin = self.limits.target_limit_margin_rad
        past = np.flatnonzero((q_target < self.lower_q - margin) | (q_target > self.upper_q + margin))
        if past.size:
            i = int(past[0])
            self.damp_for_fault(f"policy target {q_target[i]:.3f} rad at joint {i} past its limits "
                                f"[{self.lower_q[i]:.3f}, {self.upper_q[i]:.3f}] by more than {margin} rad "
                                f"(out-of-range output)", now_s, state)
            return False
        return True

    def advance(self, now_s: float, state: RobotState | None) -> None:
        """The timed transitions: the move ends in hold; with autostart, a hold ends in the policy."""
        if self.mode is Mode.PASSIVE and self.autostart and state is not None:
            self.go(Mode.MOVE_TO_DEFAULT, "autostart", now_s, state)
        elif self.mode is Mode.MOVE_TO_DEFAULT and now_s - self.entered_s >= self.limits.move_duration_s:
            self.go(Mode.HOLD, f"default pose reached after {self.limits.move_duration_s} s", now_s, state)
        elif self.mode is Mode.HOLD and self.autostart and now_s - self.entered_s >= self.limits.autostart_hold_s:
            self.go(Mode.POLICY, f"autostart after a hold of {self.limits.autostart_hold_s} s", now_s, state)
