"""The G1 in plain MuJoCo behind its DDS topics, so that `agile deploy` runs without a robot (`agile sim_robot`).

`G1Simulation` is the physics alone: the robot's MJCF built as `sim2mujoco` builds it, each motor command applied
as the robot's motor drivers do (per-motor PD from q, dq, kp, kd plus tau, within the robot config's torque-speed
limits), at the physics step; a gantry holds the pelvis in place until `gantry_release_s` after the first command
with stiffness (the robot hangs while the controller is passive and moves to its default pose, as on a real
gantry). `DDSRobotSimulator` steps it in real time, publishes LowState_ every physics step and applies the newest
LowCmd_, with fault switches: command latency, dropped state messages, a frozen state stream."""

from __future__ import annotations

import gc
import math
import threading
import time
from collections import deque
from dataclasses import dataclass
from importlib import resources

import numpy as np
import yaml

from agile.deploy.robots import ROBOTS
from agile.deploy.unitree_g1 import G1RobotSide, MotorCommand, Remote
from agile.deploy.mujoco_robot import Robot, build_model, rotate_inverse

FALL_TILT_RAD = math.radians(60.0)
FALL_HEIGHT_FRACTION = 0.5  # of the default root height, as sim2mujoco's


def g1_robot_config() -> dict:
    """The G1's robot config shipped with agile (agile/data/deploy/g1_robot.yaml)."""
    return yaml.safe_load(resources.files("agile.data.deploy").joinpath("g1_robot.yaml").read_text())


class G1Simulation:
    def __init__(self, robot_cfg: dict, physics_dt_s: float | None = None, gantry_release_s: float = 2.5):
        import mujoco

        from agile.assets import asset_file

        self.mujoco = mujoco
        cfg = dict(robot_cfg, physics_dt_s=physics_dt_s or robot_cfg["physics_dt_s"])
        self.dt_s = cfg["physics_dt_s"]
        self.model = build_model(cfg, asset_file(ROBOTS["g1"].mjcf))
        self.data = mujoco.MjData(self.model)
        self.robot = Robot(cfg, self.model)
        motor = {name: i for i, name in enumerate(ROBOTS["g1"].motor_joints)}
        self.motor_ids = np.array([motor[n] for n in cfg["joint_names"]])  # robot-config joint i is motor motor_ids[i]
        self.default_root_height_m = cfg["default_root_height_m"]
        self.data.qpos[2] = self.default_root_height_m
        self.data.qpos[self.robot.qpos_adr] = self.robot.default_q
        mujoco.mj_forward(self.model, self.data)
        self.base_pose = self.data.qpos[:7].copy()
        self.gantry_release_s = gantry_release_s
        self.stiff_since_s: float | None = None
        self.time_s = 0.0
        self.command: MotorCommand | None = None
        self.tau = np.zeros(len(cfg["joint_names"]))
        self.fell_at_s: float | None = None

    @property
    def on_gantry(self) -> bool:
        return self.stiff_since_s is None or self.time_s - self.stiff_since_s < self.gantry_release_s

    def apply(self, command: MotorCommand) -> None:
        self.command = command
        if self.stiff_since_s is None and np.any(command.kp > 0):
            self.stiff_since_s = self.time_s

    def step(self) -> None:
        data, r = self.data, self.robot
        q, qd = data.qpos[r.qpos_adr], data.qvel[r.dof_adr]
        tau = np.zeros_like(q)
        c = self.command
        if c is not None:
            ids = self.motor_ids
            tau = c.kp[ids] * (c.q[ids] - q) + c.kd[ids] * (c.dq[ids] - qd) + c.tau[ids]
            tau = np.where(c.enabled[ids], r.clip_torque(tau, qd), 0.0)
        self.tau = tau
        data.qfrc_applied[r.dof_adr] = tau
        self.mujoco.mj_step(self.model, data)
        self.time_s += self.dt_s
        if self.on_gantry:  # the pelvis put back after each step: the joints move, the base does not
            data.qpos[:7], data.qvel[:6] = self.base_pose, 0.0
        if self.fell_at_s is None and (self.tilt_rad() > FALL_TILT_RAD
                                       or data.qpos[2] < FALL_HEIGHT_FRACTION * self.default_root_height_m):
            self.fell_at_s = self.time_s

    def tilt_rad(self) -> float:
        gravity_z = rotate_inverse(self.data.qpos[3:7], np.array([0.0, 0.0, -1.0]))[2]
        return math.acos(max(-1.0, min(1.0, -gravity_z)))

    def sensors(self) -> dict:
        """What LowState_ carries, in motor order: joint q/dq/tau, the pelvis IMU (quaternion, gyro, accelerometer)."""
        data, r = self.data, self.robot
        n = len(ROBOTS["g1"].motor_joints)
        q, dq, tau = np.zeros(n), np.zeros(n), np.zeros(n)
        q[self.motor_ids], dq[self.motor_ids], tau[self.motor_ids] = (data.qpos[r.qpos_adr], data.qvel[r.dof_adr],
                                                                      self.tau)
        quat = data.qpos[3:7].copy()
        accel = rotate_inverse(quat, data.qacc[0:3] + np.array([0.0, 0.0, 9.81]))
        return {"q": q, "dq": dq, "tau": tau, "quat_wxyz": quat, "gyro_radps": data.qvel[3:6].copy(),
                "accel_mps2": accel}

    def sample(self) -> list[float]:
        """[time_s, vx, vy (the pelvis' centre of mass, its frame), yaw rate, height, tilt]."""
        v_b = self.robot.root_lin_vel_b(self.data)
        return [self.time_s, float(v_b[0]), float(v_b[1]), float(self.data.qvel[5]), float(self.data.qpos[2]),
                self.tilt_rad()]


@dataclass(frozen=True)
class SimFaults:
    command_latency_s: float = 0.0
    """Each command applied this long after it arrived."""
    state_drop_rate: float = 0.0
    """The fraction of state messages not published (drawn per message)."""
    freeze_after_s: float | None = None
    """From then on the same state message (tick included) is published again and again."""
    stop_after_s: float | None = None
    """From then on no state message is published (the link lost, the process alive)."""


class DDSRobotSimulator:
    """G1Simulation in real time behind `rt/lowstate` / `rt/lowcmd` (DDS started by the caller)."""

    def __init__(self, sim: G1Simulation, faults: SimFaults = SimFaults(), seed: int = 0, sample_every: int = 4):
        self.sim = sim
        self.faults = faults
        self.rng = np.random.default_rng(seed)
        self.sample_every = sample_every
        self.pending: deque = deque()
        self.lock = threading.Lock()
        self.commands = 0
        self.nonfinite_commands = 0
        self.link = G1RobotSide(self._on_command)
        self.samples: list = []
        self.overruns = 0
        self.published = 0
        self.wall_start_s = 0.0
        self.frozen: dict | None = None

    def _on_command(self, command: MotorCommand) -> None:
        values = np.concatenate([command.q, command.dq, command.kp, command.kd, command.tau])
        with self.lock:
            self.commands += 1
            if not np.all(np.isfinite(values)):
                self.nonfinite_commands += 1  # never applied: a driver given NaN is a fault of the controller
                return
            self.pending.append(command)

    def _due_command(self, now_s: float) -> MotorCommand | None:
        due = None
        with self.lock:
            while self.pending and self.pending[0].received_s + self.faults.command_latency_s <= now_s:
                due = self.pending.popleft()
        return due

    def run(self, duration_s: float | None, stop: threading.Event) -> dict:
        sim, faults = self.sim, self.faults
        gc.collect()
        gc.freeze()  # no whole-heap collection in the middle of a physics step
        self.wall_start_s = next_s = time.monotonic()
        tick = 0
        while not stop.is_set() and (duration_s is None or sim.time_s < duration_s):
            now_s = time.monotonic()
            command = self._due_command(now_s)
            if command is not None:
                sim.apply(command)
            sim.step()
            tick += 1
            elapsed_s = now_s - self.wall_start_s
            if faults.stop_after_s is None or elapsed_s < faults.stop_after_s:
                if faults.freeze_after_s is not None and elapsed_s >= faults.freeze_after_s:
                    self.frozen = self.frozen or dict(self.last_published)
                    self.link.publish(**self.frozen)
                    self.published += 1
                elif self.rng.random() >= faults.state_drop_rate:
                    self.last_published = dict(tick=tick, remote=Remote.pack(), **sim.sensors())
                    self.link.publish(**self.last_published)
                    self.published += 1
            if tick % self.sample_every == 0:
                self.samples.append([now_s] + sim.sample())
            next_s += sim.dt_s
            lag_s = time.monotonic() - next_s
            if lag_s > 0.05:  # behind by more than 10 steps: count it, and do not race to catch up
                self.overruns += 1
                next_s = time.monotonic()
            elif lag_s < 0:
                time.sleep(-lag_s)
        wall_s = time.monotonic() - self.wall_start_s
        return {"robot": "g1", "physics_dt_s": sim.dt_s, "sim_time_s": sim.time_s, "wall_time_s": wall_s,
                "real_time_factor": sim.time_s / wall_s if wall_s > 0 else None, "overruns": self.overruns,
                "states_published": self.published, "commands_received": self.commands,
                "commands_bad_crc": self.link.bad_crc, "commands_nonfinite": self.nonfinite_commands,
                "fell_at_sim_s": sim.fell_at_s, "faults": faults.__dict__,
                "samples_columns": ["wall_monotonic_s", "sim_time_s", "vx_mps", "vy_mps", "wz_radps", "height_m",
                                    "tilt_rad"],
                "samples": self.samples}


def walk_metrics(samples: list, start_s: float, end_s: float, command: np.ndarray) -> dict:
    """The walk between two wall-clock times (time.monotonic(), the deploy's policy start and end) from the
    simulator's samples: the mean planar velocity error and yaw-rate error as sim2mujoco and agile eval measure them,
    and whether it fell (tilt past 60 degrees or the pelvis below half its default height)."""
    rows = np.array([s for s in samples if start_s <= s[0] <= end_s])
    if rows.size == 0:
        raise ValueError(f"no simulator samples between {start_s} and {end_s}")
    lin = np.linalg.norm(rows[:, 2:4] - np.asarray(command[:2])[None], axis=1)
    ang = np.abs(rows[:, 4] - command[2])
    return {"lin_vel_error_mps": float(lin.mean()), "ang_vel_error_radps": float(ang.mean()),
            "max_tilt_rad": float(rows[:, 6].max()), "min_height_m": float(rows[:, 5].min()),
            "samples": int(len(rows)), "window_s": float(rows[-1, 0] - rows[0, 0])}
