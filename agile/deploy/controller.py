"""The deploy control loop: at the policy's control rate, the newest robot state -> the state machine's checks ->
the command of its mode -> one motor command written (none with `dry_run`).

Per mode: passive writes zero torque (kp = kd = 0); the move to the default pose interpolates from the joints'
positions at its start over `move_duration_s` with the robot config's gains; hold keeps the default pose; the policy
writes the bundle's targets, clamped to the joint limits and rate-limited to each joint's velocity limit; damping
writes kp 0 and the robot config's kd. Nothing is written before the first state message (the G1's command copies
its `mode_machine`). The loop ends `damping_s` after damping was entered."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from agile.deploy.policy import DeployPolicy, RobotState
from agile.deploy.safety import Mode, SafetyStateMachine


@dataclass
class Signals:
    """Start and stop requests from outside the loop (the keyboard, Ctrl-C), each taken once."""

    start: bool = False
    stop: str | None = None

    def take_start(self) -> bool:
        start, self.start = self.start, False
        return start


@dataclass
class StepRecord:
    period_start_s: float
    written_s: float
    state_received_s: float | None
    mode: str


@dataclass
class LoopResult:
    transitions: list
    records: list = field(default_factory=list)
    policy_started_s: float | None = None
    policy_ended_s: float | None = None
    commands_written: int = 0
    overruns: int = 0

    def timing(self, control_dt_s: float) -> dict:
        """State-to-command latency (a command's write minus the arrival of the state it was computed from) and the
        jitter of the write times against the control period, over the steps that wrote from a state [ms]."""
        rows = [r for r in self.records if r.state_received_s is not None]
        latency = np.array([r.written_s - r.state_received_s for r in rows]) * 1e3
        compute = np.array([r.written_s - r.period_start_s for r in rows]) * 1e3
        periods = np.diff([r.written_s for r in rows]) * 1e3
        stats = {}
        for name, values in (("state_to_command_ms", latency), ("compute_ms", compute)):
            if values.size:
                stats[name] = {"p50": float(np.percentile(values, 50)), "p99": float(np.percentile(values, 99)),
                               "max": float(values.max())}
        if periods.size:
            deviation = periods - control_dt_s * 1e3
            stats["period_ms"] = {"mean": float(periods.mean()), "std": float(periods.std()),
                                  "max_abs_deviation": float(np.abs(deviation).max()),
                                  "p99_abs_deviation": float(np.percentile(np.abs(deviation), 99))}
        stats["steps"] = len(rows)
        stats["overruns"] = self.overruns
        return stats


class Controller:
    def __init__(self, *, link, policy: DeployPolicy, machine: SafetyStateMachine, control_dt_s: float,
                 velocity_limit: np.ndarray, command_source, signals: Signals, dry_run: bool = False,
                 remote_buttons: bool = False):
        self.link = link
        self.policy = policy
        self.machine = machine
        self.dt_s = control_dt_s
        self.max_step = np.asarray(velocity_limit) * control_dt_s
        self.command_source = command_source
        self.signals = signals
        self.dry_run = dry_run
        self.remote_buttons = remote_buttons
        n = len(policy.default_q)
        self.zeros = np.zeros(n)
        self.previous_q = policy.default_q.copy()
        self.move_from_q = policy.default_q.copy()
        self.seen_state = False

    def command_for(self, mode: Mode, now_s: float, state: RobotState | None):
        """(q, dq, kp, kd, tau) of the mode, in motor order."""
        p, m, z = self.policy, self.machine, self.zeros
        if mode is Mode.PASSIVE:
            return z, z, z, z, z
        if mode is Mode.DAMPING:
            return z, z, z, p.kd, z
        if mode is Mode.MOVE_TO_DEFAULT:
            alpha = min(1.0, (now_s - m.entered_s) / m.limits.move_duration_s)
            q = self.move_from_q + alpha * (p.default_q - self.move_from_q)
            return q, z, p.kp, p.kd, z
        if mode is Mode.HOLD:
            return p.default_q, z, p.kp, p.kd, z
        q, kp, kd = p(state, self.command_source(state))
        if not m.check_targets(q, now_s, state):
            return z, z, z, p.kd, z
        q = np.clip(q, m.lower_q, m.upper_q)
        q = np.clip(q, self.previous_q - self.max_step, self.previous_q + self.max_step)
        return q, z, kp, kd, z

    def _signals(self, now_s: float, state: RobotState | None) -> None:
        m = self.machine
        if self.signals.stop is not None:
            m.stop(self.signals.stop, now_s, state)
        if self.remote_buttons and state is not None and state.remote:
            from agile.deploy.unitree_g1 import Remote

            buttons = Remote.parse(state.remote).buttons
            if "select" in buttons:
                m.stop("the remote's select button", now_s, state)
            elif "start" in buttons and m.mode is Mode.PASSIVE:
                m.start("the remote's start button", now_s, state)
            elif "A" in buttons and m.mode is Mode.HOLD:
                m.start("the remote's A button", now_s, state)
        if self.signals.take_start():
            m.start("the keyboard", now_s, state)

    def step(self, now_s: float, started_s: float, result: LoopResult, policy_duration_s: float | None) -> None:
        """One control period: the checks, the signals, the timed transitions, the mode's command written."""
        m = self.machine
        state = self.link.latest()
        self.seen_state = self.seen_state or state is not None
        before = m.mode  # before the checks and signals too: a start from the keyboard or the remote changes it
        m.check_state(now_s, state, started_s)
        self._signals(now_s, state)
        m.advance(now_s, state)
        if m.mode is Mode.MOVE_TO_DEFAULT and before is not Mode.MOVE_TO_DEFAULT:
            self.move_from_q = state.q.copy()
        if m.mode is Mode.POLICY and before is not Mode.POLICY:
            self.policy.reset()
            self.previous_q = self.policy.default_q.copy()
            result.policy_started_s = now_s
        if (m.mode is Mode.POLICY and policy_duration_s is not None
                and now_s - result.policy_started_s >= policy_duration_s):
            m.stop(f"--duration_s {policy_duration_s} of policy reached", now_s, state)
        if m.mode is Mode.DAMPING and result.policy_started_s is not None and result.policy_ended_s is None:
            result.policy_ended_s = now_s
        q, dq, kp, kd, tau = self.command_for(m.mode, now_s, state)
        if m.mode is Mode.POLICY:
            self.previous_q = q
        if self.seen_state and not self.dry_run:
            self.link.write(q, dq, kp, kd, tau)
            result.commands_written += 1
        result.records.append(StepRecord(now_s, time.monotonic(), None if state is None else state.received_s,
                                         m.mode.value))

    def run(self, *, policy_duration_s: float | None, damping_s: float) -> LoopResult:
        m = self.machine
        result = LoopResult(m.transitions)
        started_s = next_s = time.monotonic()
        while True:
            now_s = time.monotonic()
            self.step(now_s, started_s, result, policy_duration_s)
            if m.mode is Mode.DAMPING and now_s - m.entered_s >= damping_s:
                return result
            next_s += self.dt_s
            lag_s = time.monotonic() - next_s
            if lag_s > self.dt_s:  # a whole period late: count it, start the schedule again from now
                result.overruns += 1
                next_s = time.monotonic()
            elif lag_s < 0:
                time.sleep(-lag_s)
