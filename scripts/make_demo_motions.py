"""Write the demo dance motions shipped with agile: scripted G1 motions as CSVs in the public retargeted layout
(agile/data/motions/*.csv, 30 fps), converted by scripts/convert_motion.py's library into motion files (*.npz).

Each motion is designed in task space (pelvis pose, flat foot poses, scripted waist and arm angles); the leg
angles come from inverse kinematics of the G1 model, so a supporting foot is flat on the ground (sole at z = 0)
and does not slide. Every motion starts and ends in the standing pose, is smooth, and stays within the joint
limits (checked).

    python scripts/make_demo_motions.py            # writes agile/data/motions/
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from agile.assets.unitree_g1 import g1_beyondmimic_actuators, g1_robot_cfg
from agile.motion import SHIPPED_MOTIONS_DIR, save_motion
from agile.motion.convert import G1_CSV_JOINT_NAMES, RobotKinematics, RootAndJoints, convert_csv, write_motion_csv
from agile.sim.names import resolve_values

CSV_FPS = 30.0
CONTROL_FPS = 50.0  # the tracking task's policy rate (physics 200 Hz, decimation 4)
SOLE_BELOW_ANKLE_M = 0.037
"""Height of the ankle-roll frame above the bottom of the foot colliders when the foot is flat (g1_mjx.xml)."""
FEET = ("left_ankle_roll_link", "right_ankle_roll_link")
LEGS = {side: [f"{side}_{j}_joint" for j in ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")]
        for side in ("left", "right")}


def smoothstep(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def envelope(t, duration_s, ramp_s=0.75):
    """0 at both ends, 1 in the middle, with smooth ramps: motions start and end in the standing pose."""
    return smoothstep(t / ramp_s) * smoothstep((duration_s - t) / ramp_s)


class LegIk:
    """Leg angles that put each foot frame at a target pose, for a given pelvis pose (damped least squares on
    a finite-difference Jacobian of the model's forward kinematics)."""

    def __init__(self, kinematics: RobotKinematics):
        self.kin = kinematics
        self.foot_ids = [kinematics.body_names.index(f) for f in FEET]
        self.leg_ids = [[kinematics.joint_names.index(j) for j in LEGS[side]] for side in ("left", "right")]

    def foot_poses(self, root_pos, root_quat, joint_pos):
        """(frames, 2, 7) poses of the two foot frames, one frame per row of joint_pos."""
        n = joint_pos.shape[0]
        zeros = np.zeros((n, 3))
        poses, _ = self.kin.body_states(np.tile(root_pos, (n, 1)), np.tile(root_quat, (n, 1)), zeros, zeros,
                                        joint_pos, np.zeros_like(joint_pos))
        return poses[:, self.foot_ids].astype(np.float64)

    def solve(self, root_pos, root_quat, joint_pos, foot_targets, iterations=30, eps=1e-4, damping=1e-3):
        """joint_pos with the leg joints moved so the feet reach foot_targets (2, 7); starts from joint_pos."""
        q = joint_pos.astype(np.float64).copy()
        for _ in range(iterations):
            # perturb joint k of both legs at once: each foot depends on its own leg only
            trial = np.repeat(q[None], 7, axis=0)
            for k in range(6):
                for leg in self.leg_ids:
                    trial[k + 1, leg[k]] += eps
            poses = self.foot_poses(root_pos, root_quat, trial)
            worst = 0.0
            for side, leg in enumerate(self.leg_ids):
                error = self._error(poses[0, side], foot_targets[side])
                worst = max(worst, np.abs(error).max())
                jac = np.stack([(self._error(poses[0, side], poses[k + 1, side])) / eps for k in range(6)], axis=1)
                # error(current, target) is how far to go; the Jacobian maps joint steps to pose steps
                step = np.linalg.solve(jac.T @ jac + damping * np.eye(6), jac.T @ error)
                q[leg] += step
            if worst < 1e-5:
                break
        return q

    @staticmethod
    def _error(current, target):
        """(6,) position and rotation-vector difference from `current` to `target` (world frame)."""
        rot = Rotation.from_quat(target[3:]) * Rotation.from_quat(current[3:]).inv()
        return np.concatenate([target[:3] - current[:3], rot.as_rotvec()])


def foot_pose(x, y, yaw):
    """A flat foot frame standing on the ground at (x, y) with heading `yaw`."""
    return np.concatenate([[x, y, SOLE_BELOW_ANKLE_M], Rotation.from_euler("z", yaw).as_quat()])


def standing(kin: RobotKinematics):
    """Default joint angles, the pelvis height that puts the flat feet on the ground, and the feet's (x, y)."""
    default = g1_robot_cfg().init_joint_pos
    q = np.zeros(len(kin.joint_names))
    for i, v in resolve_values(default, kin.joint_names).items():
        q[i] = v
    ik = LegIk(kin)
    feet = ik.foot_poses(np.zeros(3), np.array([0, 0, 0, 1.0]), q[None])[0]
    pelvis_z = SOLE_BELOW_ANKLE_M - feet[:, 2].mean()
    return q, pelvis_z, feet[:, :2]


def scripted_arms(t, amount, q, names, swing_hz=0.8):
    """Arm swings (opposite shoulders), raised elbows and a waist twist, scaled by `amount` (0..1)."""
    phase = 2 * np.pi * swing_hz * t
    set_ = {"left_shoulder_pitch_joint": 0.5 * np.sin(phase), "right_shoulder_pitch_joint": -0.5 * np.sin(phase),
            "left_shoulder_roll_joint": 0.25 * (1 - np.cos(phase)), "right_shoulder_roll_joint": -0.25 * (1 - np.cos(phase)),
            "left_elbow_joint": 0.3 * np.sin(phase + 1.0), "right_elbow_joint": -0.3 * np.sin(phase + 1.0),
            "waist_yaw_joint": 0.3 * np.sin(0.5 * phase)}
    q = q.copy()
    for name, delta in set_.items():
        q[names.index(name)] += amount * delta
    return q


def solve_motion(kin, duration_s, pelvis_and_feet, arms_amount) -> RootAndJoints:
    """Frames at CSV_FPS: `pelvis_and_feet(t)` gives the pelvis position, pelvis yaw and the (2, 7) foot targets;
    the upper body follows `scripted_arms` scaled by `arms_amount(t)`; the legs come from IK, warm-started from
    the previous frame. The root is then lifted or lowered so that the lowest sole is at z = 0."""
    q0, _, _ = standing(kin)
    ik = LegIk(kin)
    leg_ids = [i for leg in ik.leg_ids for i in leg]
    times = np.arange(int(round(duration_s * CSV_FPS)) + 1) / CSV_FPS
    root_pos, root_quat, joint_pos = [], [], []
    previous = q0
    for t in times:
        pelvis, yaw, feet = pelvis_and_feet(t)
        quat = Rotation.from_euler("z", yaw).as_quat()
        q = scripted_arms(t, arms_amount(t), q0, kin.joint_names)
        q[leg_ids] = previous[leg_ids]
        q = ik.solve(pelvis, quat, q, feet)
        lowest_sole = ik.foot_poses(pelvis, quat, q[None])[0, :, 2].min() - SOLE_BELOW_ANKLE_M
        root_pos.append(pelvis - [0.0, 0.0, lowest_sole])
        root_quat.append(quat)
        joint_pos.append(q)
        previous = q
    return RootAndJoints(CSV_FPS, list(kin.joint_names), np.array(root_pos), np.array(root_quat), np.array(joint_pos))


def squat_arm_swing(kin, duration_s=8.0) -> RootAndJoints:
    """Standing in place: three squats (pelvis 10 cm down), a side sway with a pelvis turn, arm swings and a
    waist twist."""
    _, z0, feet_xy = standing(kin)
    feet = np.stack([foot_pose(*feet_xy[0], 0.0), foot_pose(*feet_xy[1], 0.0)])

    def pelvis_and_feet(t):
        a = envelope(t, duration_s)
        depth = 0.05 * (1 - np.cos(2 * np.pi * 3 * t / duration_s))
        sway = 0.04 * np.sin(2 * np.pi * 0.4 * t)
        return np.array([0.0, sway * a, z0 - depth * a]), 0.15 * np.sin(2 * np.pi * 0.4 * t) * a, feet

    return solve_motion(kin, duration_s, pelvis_and_feet, lambda t: envelope(t, duration_s))


def step_turn(kin, step_s=1.2, turn_per_step_rad=np.pi / 8) -> RootAndJoints:
    """Stepping in place while turning: each step shifts the pelvis over the stance foot, lifts the other foot
    6 cm and sets it down turned with the pelvis; the pelvis turns left by 4 x 22.5 deg, then back, and a last
    step brings both feet straight. Small arm swings."""
    _, z0, feet_xy = standing(kin)
    half_width = (feet_xy[0, 1] - feet_xy[1, 1]) / 2
    z_step = z0 - 0.03  # slightly bent knees keep the lifted leg's foot reachable
    turns = turn_per_step_rad * np.array([0, 1, 2, 3, 4, 3, 2, 1, 0, 0])  # pelvis yaw after k steps
    steps = len(turns) - 1
    pause_s = 0.75
    duration_s = 2 * pause_s + steps * step_s

    def foot_at(side, yaw):  # side 0: left, 1: right; feet stay half_width from the centre, across the heading
        sign = 1.0 if side == 0 else -1.0
        return foot_pose(-np.sin(yaw) * half_width * sign, np.cos(yaw) * half_width * sign, yaw)

    def pelvis_and_feet(t):
        k = int(np.clip((t - pause_s) // step_s, 0, steps - 1))
        u = float(np.clip((t - pause_s - k * step_s) / step_s, 0.0, 1.0))
        swing, stance = k % 2, 1 - k % 2  # the left foot swings at even steps
        # the swing foot was set down (step k-2) at turns[k-1]; the stance foot (step k-1) at turns[k]
        s = smoothstep((u - 0.3) / 0.4)  # the swing, within 30-70% of the step
        swing_yaw = (1 - s) * turns[max(k - 1, 0)] + s * turns[k + 1]
        feet = np.zeros((2, 7))
        feet[stance] = foot_at(stance, turns[k])
        start, end = foot_at(swing, turns[max(k - 1, 0)]), foot_at(swing, turns[k + 1])
        feet[swing] = foot_at(swing, swing_yaw)
        feet[swing, :3] = (1 - s) * start[:3] + s * end[:3] + [0.0, 0.0, 0.06 * np.sin(np.pi * s)]
        over_stance = np.sin(np.pi * smoothstep(u / 0.9))  # the pelvis moves over the stance foot and back
        pelvis = np.array([*(0.7 * over_stance * feet[stance, :2]), z_step])
        return pelvis, (1 - s) * turns[k] + s * turns[k + 1], feet

    return solve_motion(kin, duration_s, pelvis_and_feet, lambda t: 0.5 * envelope(t, duration_s))


MOTIONS = {"g1_squat_arm_swing": squat_arm_swing, "g1_step_turn": step_turn}


def check_motion(name: str, motion: RootAndJoints, kin: RobotKinematics) -> None:
    """Raise unless the motion is within the joint limits and has no jumps (> 0.1 rad between frames)."""
    lower = kin.model.joint_limit_lower.numpy()[6:]
    upper = kin.model.joint_limit_upper.numpy()[6:]
    outside = [kin.joint_names[j] for j in range(len(lower))
               if (motion.joint_pos[:, j] < lower[j]).any() or (motion.joint_pos[:, j] > upper[j]).any()]
    if outside:
        raise ValueError(f"{name}: joints outside their limits: {outside}")
    jump = np.abs(np.diff(motion.joint_pos, axis=0)).max()
    if jump > 0.1:
        raise ValueError(f"{name}: a joint moves {jump:.3f} rad between two frames at {CSV_FPS} fps")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out_dir", type=Path, default=SHIPPED_MOTIONS_DIR)
    args = parser.parse_args()
    robot = g1_robot_cfg(g1_beyondmimic_actuators())
    kin = RobotKinematics(robot)
    for name, make in MOTIONS.items():
        motion = make(kin)
        check_motion(name, motion, kin)
        csv_motion = RootAndJoints(motion.fps, list(G1_CSV_JOINT_NAMES), motion.root_pos_w, motion.root_quat_w,
                                   motion.joint_pos[:, [kin.joint_names.index(j) for j in G1_CSV_JOINT_NAMES]])
        csv_path = args.out_dir / f"{name}.csv"
        write_motion_csv(csv_path, csv_motion)
        save_motion(args.out_dir / f"{name}.npz", convert_csv(csv_path, CSV_FPS, CONTROL_FPS, robot))
        print(f"{name}: {motion.joint_pos.shape[0]} frames at {CSV_FPS:g} fps -> {csv_path} and .npz")


if __name__ == "__main__":
    main()
