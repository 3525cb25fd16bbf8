"""The motion file: one reference motion of a robot, at the policy's control rate, as a NumPy `.npz`.

Arrays (T frames, J joints, B bodies; world frame, z up; quaternions (x, y, z, w)):

| key              | shape      | meaning                                                                   |
|------------------|------------|---------------------------------------------------------------------------|
| `format_version` | ()         | `FORMAT_VERSION`                                                          |
| `fps`            | ()         | frames per second [Hz]: the control rate of the task that tracks it       |
| `joint_names`    | (J,)       | the robot's joints, in the order of the joint arrays                      |
| `body_names`     | (B,)       | the robot's bodies, in the order of the body arrays                       |
| `joint_pos`      | (T, J)     | joint positions [rad]                                                     |
| `joint_vel`      | (T, J)     | joint velocities [rad/s]                                                  |
| `body_pos_w`     | (T, B, 3)  | body frame origins [m]                                                    |
| `body_quat_w`    | (T, B, 4)  | body orientations                                                         |
| `body_lin_vel_w` | (T, B, 3)  | linear velocity of each body's centre of mass [m/s] (the simulator's      |
|                  |            | `body_vel_w` convention)                                                  |
| `body_ang_vel_w` | (T, B, 3)  | angular velocity of each body [rad/s]                                     |

The body arrays are the forward kinematics of the same robot model the task simulates (`agile.motion.convert`),
so a motion loads only into a robot with the same joint and body names.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agile.utils.files import resolve_shipped_file

FORMAT_VERSION = 1
SHIPPED_MOTIONS_DIR = Path(__file__).resolve().parents[1] / "data" / "motions"
"""The motions shipped with agile (`scripts/make_demo_motions.py` writes them)."""


@dataclass
class MotionData:
    fps: float
    joint_names: list[str]
    body_names: list[str]
    joint_pos: np.ndarray
    joint_vel: np.ndarray
    body_pos_w: np.ndarray
    body_quat_w: np.ndarray
    body_lin_vel_w: np.ndarray
    body_ang_vel_w: np.ndarray

    @property
    def num_frames(self) -> int:
        return self.joint_pos.shape[0]

    @property
    def duration_s(self) -> float:
        return (self.num_frames - 1) / self.fps

    def check(self, where: str) -> None:
        """Raise ValueError naming `where` and the array unless the shapes agree and the values are finite."""
        t, j, b = self.num_frames, len(self.joint_names), len(self.body_names)
        expected = {"joint_pos": (t, j), "joint_vel": (t, j), "body_pos_w": (t, b, 3), "body_quat_w": (t, b, 4),
                    "body_lin_vel_w": (t, b, 3), "body_ang_vel_w": (t, b, 3)}
        for key, shape in expected.items():
            value = getattr(self, key)
            if value.shape != shape:
                raise ValueError(f"{where}: '{key}' has shape {value.shape}, expected {shape} "
                                 f"({t} frames, {j} joints, {b} bodies)")
            if not np.isfinite(value).all():
                raise ValueError(f"{where}: '{key}' holds non-finite values")
        if t < 2:
            raise ValueError(f"{where}: a motion needs at least 2 frames, got {t}")
        if not self.fps > 0:
            raise ValueError(f"{where}: fps must be positive, got {self.fps}")


def save_motion(path: str | Path, motion: MotionData) -> None:
    """Write `motion` to `path` (.npz), through a temporary file renamed into place."""
    path = Path(path)
    motion.check(str(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez_compressed(tmp, format_version=np.int64(FORMAT_VERSION), fps=np.float64(motion.fps),
                        joint_names=np.array(motion.joint_names), body_names=np.array(motion.body_names),
                        joint_pos=motion.joint_pos.astype(np.float32), joint_vel=motion.joint_vel.astype(np.float32),
                        body_pos_w=motion.body_pos_w.astype(np.float32),
                        body_quat_w=motion.body_quat_w.astype(np.float32),
                        body_lin_vel_w=motion.body_lin_vel_w.astype(np.float32),
                        body_ang_vel_w=motion.body_ang_vel_w.astype(np.float32))
    tmp.replace(path)


def resolve_motion_file(name: str | Path) -> Path:
    """`name` as a path, else as a shipped motion (with or without `.npz`)."""
    return resolve_shipped_file(name, SHIPPED_MOTIONS_DIR, ".npz", "motion")


def load_motion(name: str | Path) -> MotionData:
    """Read a motion file (a path, or the name of a shipped motion) and check it."""
    path = resolve_motion_file(name)
    with np.load(path) as data:
        missing = [k for k in ("format_version", "fps", "joint_names", "body_names", "joint_pos", "joint_vel",
                               "body_pos_w", "body_quat_w", "body_lin_vel_w", "body_ang_vel_w") if k not in data]
        if missing:
            raise ValueError(f"motion file '{path}' lacks {missing} (written by scripts/convert_motion.py?)")
        if int(data["format_version"]) != FORMAT_VERSION:
            raise ValueError(f"motion file '{path}' has format version {int(data['format_version'])}; this agile "
                             f"reads version {FORMAT_VERSION}: convert it again with scripts/convert_motion.py")
        motion = MotionData(fps=float(data["fps"]), joint_names=[str(n) for n in data["joint_names"]],
                            body_names=[str(n) for n in data["body_names"]],
                            **{k: data[k].astype(np.float32) for k in ("joint_pos", "joint_vel", "body_pos_w",
                                                                       "body_quat_w", "body_lin_vel_w",
                                                                       "body_ang_vel_w")})
    motion.check(str(path))
    return motion


def check_names_match(motion_names: list[str], robot_names: list[str], what: str, where: str) -> None:
    """Raise ValueError unless the motion holds every name of the robot (order may differ), naming the missing."""
    missing = [n for n in robot_names if n not in motion_names]
    if missing:
        raise ValueError(f"{where}: the motion lacks the robot's {what}s {missing}. Motion {what}s: {motion_names}")
