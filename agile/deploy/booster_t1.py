"""The Booster T1 (23 joints) over the Booster SDK (`booster_robotics_sdk_python`, the `agile[deploy]` extra, its
own Fast-DDS): `B1LowStateSubscriber` on `rt/low_state` in, `B1LowCmdPublisher` out, in the robot's custom mode
(`B1LocoClient.ChangeMode(RobotMode.kCustom)`, entered from its prepare mode; left for damping at the end).

What the SDK's Python binding (1.6.3) does not give, and so what is not done here: no LowState publisher and no LowCmd
subscriber (the robot's side of the link cannot be written in Python, so `agile sim_robot` has no T1 and no T1
loop runs in a test); its LowState has no message counter (a frozen stream is caught only as a lost link when it
stops) and its IMU gives roll, pitch and yaw, no quaternion (the orientation is rebuilt from them)."""

from __future__ import annotations

import threading
import time

import numpy as np

from agile.deploy.policy import RobotState, quat_from_rpy
from agile.deploy.robots import ROBOTS
from agile.deploy.unitree_g1 import check_interface

MOTORS = len(ROBOTS["t1"].motor_joints)


def start_dds(interface: str, domain_id: int) -> None:
    import booster_robotics_sdk_python as booster

    check_interface(interface)
    booster.ChannelFactory.Instance().Init(domain_id, interface)


def robot_state(msg, received_s: float, count: int) -> RobotState:
    """A Booster LowState as RobotState: the serial (joint-space) motor states, the IMU's rpy as a quaternion;
    `count` (the messages received so far) stands in for the tick the message lacks."""
    motors = list(msg.motor_state_serial)[:MOTORS]
    imu = msg.imu_state
    return RobotState(q=np.array([m.q for m in motors]), dq=np.array([m.dq for m in motors]),
                      tau=np.array([m.tau_est for m in motors]), quat_wxyz=quat_from_rpy(*imu.rpy),
                      gyro_radps=np.array(imu.gyro, dtype=float), tick=count, received_s=received_s)


def low_cmd(q, dq, kp, kd, tau):
    """A serial (joint-space) LowCmd of the 23 joints."""
    import booster_robotics_sdk_python as booster

    cmd = booster.LowCmd()
    cmd.cmd_type = booster.LowCmdType.SERIAL
    motors = []
    for i in range(MOTORS):
        motor = booster.MotorCmd()
        motor.q, motor.dq, motor.kp, motor.kd, motor.tau = (float(q[i]), float(dq[i]), float(kp[i]), float(kd[i]),
                                                            float(tau[i]))
        motor.weight = 0.0  # the SDK's examples: weight has no effect in the custom mode
        motors.append(motor)
    cmd.motor_cmd = motors
    return cmd


class T1Link:
    """The controller's side: the newest LowState as RobotState, write() of one LowCmd."""

    def __init__(self):
        import booster_robotics_sdk_python as booster

        self.booster = booster
        self.lock = threading.Lock()
        self.state: RobotState | None = None
        self.received = 0
        self.bad_crc = 0  # the Booster messages carry no CRC: never counted
        self.written = 0
        self.publisher = booster.B1LowCmdPublisher()
        self.publisher.InitChannel()
        self.subscriber = booster.B1LowStateSubscriber(self._on_state)
        self.subscriber.InitChannel()
        self.loco = None

    def _on_state(self, msg) -> None:
        received_s = time.monotonic()
        with self.lock:
            self.received += 1
            self.state = robot_state(msg, received_s, self.received)

    def latest(self) -> RobotState | None:
        with self.lock:
            return self.state

    def enter_custom_mode(self) -> None:
        """The robot's low-level mode (from its prepare mode), through the locomotion service's RPC."""
        self.loco = self.booster.B1LocoClient()
        self.loco.Init()
        self.loco.ChangeMode(self.booster.RobotMode.kCustom)

    def write(self, q, dq, kp, kd, tau) -> None:
        self.publisher.Write(low_cmd(q, dq, kp, kd, tau))
        self.written += 1

    def close(self) -> None:
        if self.loco is not None:
            self.loco.ChangeMode(self.booster.RobotMode.kDamping)
        self.subscriber.CloseChannel()
        self.publisher.CloseChannel()
