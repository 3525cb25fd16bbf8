"""The pick-and-place trajectory file: keyframes of the upper body and the object, as YAML.

```yaml
format_version: 1
description: right hand picks the cube at (0.35, -0.15) and places it 20 cm to the left   # free text
anchor_body: torso_link          # the body whose pose `anchor_pos_m` / `anchor_quat_xyzw` give
joint_names: [waist_yaw_joint, ..., right_hand_index_1_joint]   # the tracked joints, order of `joint_pos`
frames:                          # at least 2, `time_s` strictly increasing from 0
  - time_s: 0.0                  # [s]
    phase: approach              # one of PHASES (below)
    joint_pos: [0.0, ...]        # [rad], one per joint name: the upper body's target at this time
    object_pos_m: [0.35, -0.15, 0.83]      # the object's centre, env frame [m]
    object_quat_xyzw: [0.0, 0.0, 0.0, 1.0]
    anchor_pos_m: [0.0, 0.0, 1.0]          # the anchor body, env frame [m]
    anchor_quat_xyzw: [0.0, 0.0, 0.0, 1.0]
```

The env frame has world axes and its origin at the env's origin on the ground; the robot starts at its default
root pose there, facing +x. Between keyframes, positions and joint angles are interpolated linearly and
orientations by spherical linear interpolation; the phase is that of the last keyframe at or before the time.
`scripts/make_pick_place_trajectories.py` writes the shipped files (`agile/data/trajectories/`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from agile.utils.files import resolve_shipped_file

FORMAT_VERSION = 1
PHASES = ("approach", "grasp", "carry", "release", "retract")
"""approach: the hand moves to the resting object; grasp: the fingers close on it; carry: the object moves with
the hand (lift, move, lower); release: the fingers open, the object rests at its goal; retract: the hand
moves away."""
IN_HAND_PHASES = ("grasp", "carry")
"""Phases in which the hand holds the object (the hand-object distance is tracked)."""
FRAME_FIELDS = {"time_s": 1, "phase": 0, "joint_pos": None, "object_pos_m": 3, "object_quat_xyzw": 4,
                "anchor_pos_m": 3, "anchor_quat_xyzw": 4}
"""Every frame's fields and their lengths (None: one per joint name; 0: a phase name)."""
SHIPPED_TRAJECTORIES_DIR = Path(__file__).resolve().parents[1] / "data" / "trajectories"


@dataclass
class Trajectory:
    """A trajectory: keyframes as read, or resampled at a fixed step (`resample`)."""

    joint_names: list[str]
    anchor_body: str
    time_s: np.ndarray            # (T,)
    phase: np.ndarray             # (T,) indices into PHASES
    joint_pos: np.ndarray         # (T, J)
    object_pos_m: np.ndarray      # (T, 3)
    object_quat_xyzw: np.ndarray  # (T, 4)
    anchor_pos_m: np.ndarray      # (T, 3)
    anchor_quat_xyzw: np.ndarray  # (T, 4)

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1])


def resolve_trajectory_file(name: str | Path) -> Path:
    """`name` as a path, else as a shipped trajectory (with or without `.yaml`)."""
    return resolve_shipped_file(name, SHIPPED_TRAJECTORIES_DIR, ".yaml", "trajectory")


def load_trajectory(name: str | Path) -> Trajectory:
    """Read and check a trajectory file (a path, or the name of a shipped trajectory)."""
    path = resolve_trajectory_file(name)
    with open(path) as f:
        data = yaml.safe_load(f)
    where = f"trajectory file {path}"
    for key in ("format_version", "anchor_body", "joint_names", "frames"):
        if key not in data:
            raise ValueError(f"{where}: missing '{key}'")
    if data["format_version"] != FORMAT_VERSION:
        raise ValueError(f"{where}: format_version {data['format_version']}, this agile reads {FORMAT_VERSION}")
    joint_names = list(data["joint_names"])
    frames = data["frames"]
    if len(frames) < 2:
        raise ValueError(f"{where}: {len(frames)} frames; at least 2 are needed")
    for i, frame in enumerate(frames):
        unknown = sorted(set(frame) - set(FRAME_FIELDS))
        missing = [k for k in FRAME_FIELDS if k not in frame]
        if unknown or missing:
            raise ValueError(f"{where}: frames[{i}] has unknown fields {unknown}, misses {missing}; fields: "
                             f"{list(FRAME_FIELDS)}")
        if frame["phase"] not in PHASES:
            raise ValueError(f"{where}: frames[{i}].phase '{frame['phase']}' is not a phase: {list(PHASES)}")
        for key, length in FRAME_FIELDS.items():
            length = len(joint_names) if length is None else length
            if length > 1 and len(frame[key]) != length:
                raise ValueError(f"{where}: frames[{i}].{key} has {len(frame[key])} values, expected {length}")

    def column(key):
        return np.asarray([frame[key] for frame in frames], dtype=np.float64)

    time_s = column("time_s")
    if time_s[0] != 0.0 or not np.all(np.diff(time_s) > 0.0):
        raise ValueError(f"{where}: frames' time_s must start at 0 and increase strictly, got {time_s.tolist()}")
    return Trajectory(joint_names=joint_names, anchor_body=str(data["anchor_body"]), time_s=time_s,
                      phase=np.asarray([PHASES.index(frame["phase"]) for frame in frames]),
                      joint_pos=column("joint_pos"), object_pos_m=column("object_pos_m"),
                      object_quat_xyzw=_normalised(column("object_quat_xyzw")), anchor_pos_m=column("anchor_pos_m"),
                      anchor_quat_xyzw=_normalised(column("anchor_quat_xyzw")))


def _normalised(q: np.ndarray) -> np.ndarray:
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def slerp(q0: np.ndarray, q1: np.ndarray, fraction: np.ndarray) -> np.ndarray:
    """(K, 4) spherical linear interpolation between unit quaternions q0 and q1 (K, 4), by the shorter way."""
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0.0, -q1, q1)
    dot = np.abs(dot)
    angle = np.arccos(np.clip(dot, -1.0, 1.0))
    sin = np.sin(angle)
    f = fraction[:, None]
    safe = sin > 1e-6
    w0 = np.where(safe, np.sin((1.0 - f) * angle) / np.where(safe, sin, 1.0), 1.0 - f)
    w1 = np.where(safe, np.sin(f * angle) / np.where(safe, sin, 1.0), f)
    return _normalised(w0 * q0 + w1 * q1)


def sample(trajectory: Trajectory, times_s: np.ndarray) -> Trajectory:
    """The trajectory at `times_s` (clamped to its span): linear in positions and angles, slerp in orientations,
    the phase of the last keyframe at or before each time."""
    t = np.clip(np.asarray(times_s, dtype=np.float64), 0.0, trajectory.duration_s)
    upper = np.clip(np.searchsorted(trajectory.time_s, t, side="right"), 1, len(trajectory.time_s) - 1)
    lower = upper - 1
    t0, t1 = trajectory.time_s[lower], trajectory.time_s[upper]
    fraction = (t - t0) / (t1 - t0)

    def lerp(values):
        return values[lower] + fraction[:, None] * (values[upper] - values[lower])

    phase = np.where(fraction >= 1.0, trajectory.phase[upper], trajectory.phase[lower])
    return Trajectory(joint_names=trajectory.joint_names, anchor_body=trajectory.anchor_body, time_s=t,
                      phase=phase, joint_pos=lerp(trajectory.joint_pos), object_pos_m=lerp(trajectory.object_pos_m),
                      object_quat_xyzw=slerp(trajectory.object_quat_xyzw[lower], trajectory.object_quat_xyzw[upper],
                                             fraction),
                      anchor_pos_m=lerp(trajectory.anchor_pos_m),
                      anchor_quat_xyzw=slerp(trajectory.anchor_quat_xyzw[lower], trajectory.anchor_quat_xyzw[upper],
                                             fraction))


def resample(trajectory: Trajectory, step_s: float) -> Trajectory:
    """The trajectory every `step_s` seconds from 0 to its end (the last sample at or before the end)."""
    count = int(np.floor(trajectory.duration_s / step_s + 1e-9)) + 1
    return sample(trajectory, np.arange(count) * step_s)


def write_trajectory(path: str | Path, trajectory: Trajectory, description: str) -> None:
    """Write keyframes in the file format (numbers rounded to 1e-5; a zero is written 0.0, whatever its sign)."""
    def row(values):
        # + 0.0 turns -0.0 into 0.0: the sign of a zero depends on the solver's last rounding, not on the data
        return [round(float(v), 5) + 0.0 for v in values]

    frames = [{"time_s": round(float(trajectory.time_s[i]), 5), "phase": PHASES[int(trajectory.phase[i])],
               "joint_pos": row(trajectory.joint_pos[i]), "object_pos_m": row(trajectory.object_pos_m[i]),
               "object_quat_xyzw": row(trajectory.object_quat_xyzw[i]), "anchor_pos_m": row(trajectory.anchor_pos_m[i]),
               "anchor_quat_xyzw": row(trajectory.anchor_quat_xyzw[i])} for i in range(len(trajectory.time_s))]
    data = {"format_version": FORMAT_VERSION, "description": description, "anchor_body": trajectory.anchor_body,
            "joint_names": list(trajectory.joint_names), "frames": frames}
    with open(path, "w") as f:
        yaml.safe_dump(data, f, sort_keys=False, default_flow_style=None, width=120)
