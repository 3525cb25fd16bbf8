"""What the deploy tests build their parts from: a robot state, the safety state machine, a policy with a chosen
output, a controller around them, a link that records what it writes, a clock set by hand."""

from __future__ import annotations

import numpy as np

from agile.deploy.controller import Controller, Signals
from agile.deploy.policy import RobotState
from agile.deploy.safety import SafetyLimits, SafetyStateMachine

N = 29
LOWER, UPPER = np.full(N, -1.0), np.full(N, 1.0)


def state(now_s=0.0, tick=0, q=None, quat=(1.0, 0.0, 0.0, 0.0)) -> RobotState:
    return RobotState(q=np.zeros(N) if q is None else q, dq=np.zeros(N), tau=np.zeros(N), quat_wxyz=np.array(quat),
                      gyro_radps=np.zeros(3), tick=tick, received_s=now_s)


def machine(autostart=False) -> SafetyStateMachine:
    return SafetyStateMachine(SafetyLimits(max_state_age_s=0.06, move_duration_s=2.0, autostart_hold_s=1.0),
                              LOWER, UPPER, autostart=autostart)


class FakePolicy:
    """DeployPolicy's interface with a chosen output."""

    def __init__(self, output):
        self.default_q = np.full(N, 0.5)
        self.kp = np.full(N, 40.0)
        self.kd = np.full(N, 2.0)
        self.output = output

    def reset(self):
        pass

    def __call__(self, state, command):
        return self.output.copy(), self.kp, self.kd


def controller(output, mode):
    m = machine()
    m.mode = mode
    c = Controller(link=None, policy=FakePolicy(output), machine=m, control_dt_s=0.02,
                   velocity_limit=np.full(N, 10.0), command_source=lambda s: np.zeros(3), signals=Signals())
    return c, m


class FakeLink:
    def __init__(self, state):
        self.state = state
        self.written = []

    def latest(self):
        return self.state

    def write(self, q, dq, kp, kd, tau):
        self.written.append((q.copy(), kp.copy(), kd.copy()))



class Clock:
    def __init__(self):
        self.now_s = 0.0

    def __call__(self):
        return self.now_s

