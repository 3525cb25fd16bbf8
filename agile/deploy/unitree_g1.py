"""The 29-DoF Unitree G1 over Unitree's DDS (`unitree_sdk2py`, the `agile[deploy]` extra): `unitree_hg` LowState_
on `rt/lowstate` in, LowCmd_ on `rt/lowcmd` out, each with the SDK's CRC. Both sides of the link live here, the
controller's (`G1Link`) and the robot's (`G1RobotSide`, what `agile sim_robot` publishes), so that the message
layout is written once.

Command fields as Unitree's own low-level examples set them: `mode_pr` 0 (the ankles' pitch/roll mode),
`mode_machine` copied from the robot's state, every motor's `mode` 1 (enabled), q/dq/tau/kp/kd per motor."""

from __future__ import annotations

import socket
import struct
import threading
import time
from dataclasses import dataclass

import numpy as np

from agile.deploy.policy import RobotState
from agile.deploy.robots import ROBOTS, DeployError

STATE_TOPIC = "rt/lowstate"
COMMAND_TOPIC = "rt/lowcmd"
MOTORS = len(ROBOTS["g1"].motor_joints)
MODE_PR = 0
MOTOR_ENABLED = 1

REMOTE_BUTTONS = {"R1": 0, "L1": 1, "start": 2, "select": 3, "R2": 4, "L2": 5, "F1": 6, "F2": 7,
                  "A": 8, "B": 9, "X": 10, "Y": 11, "up": 12, "right": 13, "down": 14, "left": 15}
"""Bits of the wireless remote's key word (bytes 2-3 of `wireless_remote`), as unitree_rl_gym's remote_controller."""


@dataclass(frozen=True)
class Remote:
    """The wireless remote in LowState_: buttons held, sticks in [-1, 1]."""

    buttons: frozenset
    lx: float
    ly: float
    rx: float
    ry: float

    @staticmethod
    def parse(data: bytes) -> Remote:
        if len(data) < 24:
            return Remote(frozenset(), 0.0, 0.0, 0.0, 0.0)
        keys = struct.unpack_from("<H", data, 2)[0]
        lx, rx, ry = struct.unpack_from("<3f", data, 4)
        ly = struct.unpack_from("<f", data, 20)[0]
        return Remote(frozenset(n for n, bit in REMOTE_BUTTONS.items() if keys >> bit & 1), lx, ly, rx, ry)

    @staticmethod
    def pack(buttons=(), lx=0.0, ly=0.0, rx=0.0, ry=0.0) -> list[int]:
        """40 bytes of `wireless_remote` (the simulator's side; a test's)."""
        data = bytearray(40)
        struct.pack_into("<H", data, 2, sum(1 << REMOTE_BUTTONS[b] for b in buttons))
        struct.pack_into("<3f", data, 4, lx, rx, ry)
        struct.pack_into("<f", data, 20, ly)
        return list(data)

    def velocity_command(self, max_vx: float, max_vy: float, max_wz: float) -> np.ndarray:
        """Left stick forward/sideways, right stick yaw (unitree_rl_gym's mapping: vx = ly, vy = -lx, wz = -rx)."""
        return np.array([self.ly * max_vx, -self.lx * max_vy, -self.rx * max_wz])


def check_interface(name: str) -> None:
    """Raise DeployError unless `name` is a network interface of this machine (before DDS is started on it)."""
    names = [n for _, n in socket.if_nameindex()]
    if name not in names:
        raise DeployError(f"--interface: no network interface '{name}' on this machine; its interfaces: "
                          f"{', '.join(names)}")


def start_dds(interface: str, domain_id: int) -> None:
    """Unitree's channel factory on one interface and domain (once per process: the SDK keeps one participant)."""
    from unitree_sdk2py.core.channel import ChannelFactoryInitialize

    check_interface(interface)
    ChannelFactoryInitialize(domain_id, interface)


def _crc():
    from unitree_sdk2py.utils.crc import CRC

    return CRC()


class G1Link:
    """The controller's side: the newest LowState_ as RobotState (a message with a wrong CRC is not used, and
    counted), and write() of one LowCmd_. Only the newest message is checked and converted, when the loop reads it:
    at the robot's 500 Hz the listener thread would otherwise hold the GIL for most of each control period."""

    def __init__(self):
        from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
        from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
        from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowCmd_, LowState_

        self.crc = _crc()
        self.command = unitree_hg_msg_dds__LowCmd_()
        self.lock = threading.Lock()
        self.message, self.message_s, self.converted = None, 0.0, None
        self.state: RobotState | None = None
        self.mode_machine = 0
        self.bad_crc = 0
        self.received = 0
        self.written = 0
        self.publisher = ChannelPublisher(COMMAND_TOPIC, LowCmd_)
        self.publisher.Init()
        self.subscriber = ChannelSubscriber(STATE_TOPIC, LowState_)
        self.subscriber.Init(self._on_state, 1)

    def _on_state(self, msg) -> None:
        # the listener thread only keeps the message: the CRC and the conversion run for the one the loop reads
        with self.lock:
            self.message, self.message_s = msg, time.monotonic()
            self.received += 1

    def latest(self) -> RobotState | None:
        with self.lock:
            msg, received_s = self.message, self.message_s
        if msg is None or msg is self.converted:
            return self.state
        self.converted = msg
        if self.crc.Crc(msg) != msg.crc:
            self.bad_crc += 1
            return self.state
        motors = msg.motor_state[:MOTORS]
        imu = msg.imu_state
        self.state = RobotState(q=np.array([m.q for m in motors]), dq=np.array([m.dq for m in motors]),
                                tau=np.array([m.tau_est for m in motors]),
                                quat_wxyz=np.array(imu.quaternion, dtype=float),
                                gyro_radps=np.array(imu.gyroscope, dtype=float), tick=int(msg.tick),
                                received_s=received_s, remote=bytes(msg.wireless_remote))
        self.mode_machine = msg.mode_machine
        return self.state

    def write(self, q: np.ndarray, dq: np.ndarray, kp: np.ndarray, kd: np.ndarray, tau: np.ndarray) -> None:
        cmd = self.command
        cmd.mode_pr, cmd.mode_machine = MODE_PR, self.mode_machine
        for i in range(MOTORS):
            motor = cmd.motor_cmd[i]
            motor.mode = MOTOR_ENABLED
            motor.q, motor.dq, motor.kp, motor.kd, motor.tau = (float(q[i]), float(dq[i]), float(kp[i]),
                                                                float(kd[i]), float(tau[i]))
        cmd.crc = self.crc.Crc(cmd)
        self.publisher.Write(cmd)
        self.written += 1

    def close(self) -> None:
        """Close the command writer. The state reader stays until the process ends: deleting a cyclonedds reader
        while its listener thread waits for the GIL can deadlock."""
        self.publisher.Close()


class VelocityTopic:
    """A velocity command over DDS: `geometry_msgs/Twist` (linear.x, linear.y, angular.z = vx, vy, wz) on `topic`,
    in the DDS type unitree_sdk2py ships for it (`geometry_msgs::msg::dds_::Twist_`, ROS 2's: a ROS 2 node's
    `/cmd_vel` is the DDS topic `rt/cmd_vel`). Each message is handed to `on_velocity(vx, vy, wz)` from the
    listener's thread. `publish` is the sender's side (a teleoperation script's, a test's)."""

    def __init__(self, topic: str, on_velocity=None):
        from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
        from unitree_sdk2py.idl.geometry_msgs.msg.dds_ import Twist_

        self.topic = topic
        self.on_velocity = on_velocity
        if on_velocity is None:
            self.publisher = ChannelPublisher(topic, Twist_)
            self.publisher.Init()
        else:
            self.subscriber = ChannelSubscriber(topic, Twist_)
            self.subscriber.Init(self._on_message, 1)

    def _on_message(self, msg) -> None:
        self.on_velocity(float(msg.linear.x), float(msg.linear.y), float(msg.angular.z))

    def publish(self, vx: float, vy: float, wz: float) -> None:
        from unitree_sdk2py.idl.geometry_msgs.msg.dds_ import Twist_, Vector3_

        self.publisher.Write(Twist_(Vector3_(float(vx), float(vy), 0.0), Vector3_(0.0, 0.0, float(wz))))


@dataclass
class MotorCommand:
    """One LowCmd_ as the motor drivers apply it, in motor order; `received_s` its arrival (time.monotonic())."""

    q: np.ndarray
    dq: np.ndarray
    kp: np.ndarray
    kd: np.ndarray
    tau: np.ndarray
    enabled: np.ndarray
    received_s: float


class G1RobotSide:
    """The robot's side (the simulator's): publish() one LowState_, and each valid LowCmd_ handed to
    `on_command(MotorCommand)`; commands with a wrong CRC are dropped and counted."""

    def __init__(self, on_command):
        from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
        from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowState_
        from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowCmd_, LowState_

        self.crc = _crc()
        self.on_command = on_command
        self.state = unitree_hg_msg_dds__LowState_()
        self.bad_crc = 0
        self.publisher = ChannelPublisher(STATE_TOPIC, LowState_)
        self.publisher.Init()
        self.subscriber = ChannelSubscriber(COMMAND_TOPIC, LowCmd_)
        self.subscriber.Init(self._on_command, 1)

    def _on_command(self, msg) -> None:
        received_s = time.monotonic()
        if self.crc.Crc(msg) != msg.crc:
            self.bad_crc += 1
            return
        motors = msg.motor_cmd[:MOTORS]
        self.on_command(MotorCommand(
            q=np.array([m.q for m in motors]), dq=np.array([m.dq for m in motors]),
            kp=np.array([m.kp for m in motors]), kd=np.array([m.kd for m in motors]),
            tau=np.array([m.tau for m in motors]), enabled=np.array([m.mode == MOTOR_ENABLED for m in motors]),
            received_s=received_s))

    def publish(self, tick: int, q, dq, tau, quat_wxyz, gyro_radps, accel_mps2, remote: list[int]) -> None:
        msg = self.state
        msg.tick = tick
        msg.mode_pr = MODE_PR
        msg.imu_state.quaternion = [float(v) for v in quat_wxyz]
        msg.imu_state.gyroscope = [float(v) for v in gyro_radps]
        msg.imu_state.accelerometer = [float(v) for v in accel_mps2]
        for i in range(MOTORS):
            motor = msg.motor_state[i]
            motor.q, motor.dq, motor.tau_est = float(q[i]), float(dq[i]), float(tau[i])
        msg.wireless_remote = remote
        msg.crc = self.crc.Crc(msg)
        self.publisher.Write(msg)
