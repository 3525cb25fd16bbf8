"""Write the shipped pick-and-place trajectories (agile/data/trajectories/*.yaml).

    python scripts/make_pick_place_trajectories.py                 # into agile/data/trajectories/
    python scripts/make_pick_place_trajectories.py --out /tmp/traj

Each trajectory is a few palm keyframes (above and behind the cube, at the cube, lifted, over the goal, at the
goal, pulled back) solved by damped-least-squares inverse kinematics on the right arm of the MuJoCo model of the
G1 with hands (root fixed at its default pose), with scripted waist and finger angles. Between keyframes the
joints ease in and out (smoothstep); the cube rides with the palm while the hand holds it. Frames are written
every 0.1 s, which the loader interpolates linearly (agile/motion/trajectory_file.py).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from agile.assets.tabletop import CUBE_START_POS_M
from agile.assets.unitree_g1 import INIT_HEIGHT_M
from agile.assets.unitree_g1_with_hands import PALM_BODY, PALM_OFFSET_M, g1_with_hands_robot_cfg
from agile.motion.trajectory_file import PHASES, SHIPPED_TRAJECTORIES_DIR, Trajectory, write_trajectory
from agile.sim.names import resolve_values

ANCHOR_BODY = "torso_link"
TRACKED_JOINTS = ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint",
                  "right_shoulder_pitch_joint", "right_shoulder_roll_joint", "right_shoulder_yaw_joint",
                  "right_elbow_joint", "right_wrist_roll_joint", "right_wrist_pitch_joint", "right_wrist_yaw_joint",
                  "right_hand_thumb_0_joint", "right_hand_thumb_1_joint", "right_hand_thumb_2_joint",
                  "right_hand_middle_0_joint", "right_hand_middle_1_joint", "right_hand_index_0_joint",
                  "right_hand_index_1_joint"]
ARM_JOINTS = TRACKED_JOINTS[3:10]
HAND_CLOSED = {"right_hand_thumb_1_joint": 0.5, "right_hand_thumb_2_joint": -0.8, "right_hand_middle_0_joint": 0.9,
               "right_hand_middle_1_joint": 0.8, "right_hand_index_0_joint": 0.9, "right_hand_index_1_joint": 0.8}
"""Finger angles around a 6 cm cube [rad] (an open hand is all zeros)."""
WAIST_PITCH_REACHING_RAD = 0.1
"""A slight forward lean from the approach to the release."""
FRAME_STEP_S = 0.1
ROTATION_WEIGHT = 0.1
"""How much the inverse kinematics trades palm position [m] for the hand's orientation [rad]: a soft preference."""
LIFT_M = 0.12
PRE_GRASP_OFFSET_M = np.array([-0.10, 0.0, 0.06])
"""The palm's keyframe before the grasp: behind and above the cube."""
GOALS_M = {  # name: (cube goal xy offset from its start [m], description)
    "pick_place_left": ((0.0, 0.15), "pick the cube up and put it down 15 cm to the left"),
    "pick_place_near_left": ((0.0, 0.08), "pick the cube up and put it down 8 cm to the left"),
    "pick_place_right": ((-0.02, -0.10), "pick the cube up and put it down 10 cm to the right, 2 cm nearer"),
}


class G1Kinematics:
    """MuJoCo model of the G1 with hands, root fixed at its default pose; forward and inverse kinematics."""

    def __init__(self):
        cfg = g1_with_hands_robot_cfg()
        self.model = mujoco.MjModel.from_xml_path(cfg.model_file)
        self.data = mujoco.MjData(self.model)
        self.joint_names = [self.model.joint(i).name for i in range(1, self.model.njnt)]  # after the free root
        self.qpos_adr = {n: self.model.joint(n).qposadr[0] for n in self.joint_names}
        self.dof_adr = {n: self.model.joint(n).dofadr[0] for n in self.joint_names}
        self.default = {n: 0.0 for n in self.joint_names}
        for i, value in resolve_values(cfg.init_joint_pos, self.joint_names).items():
            self.default[self.joint_names[i]] = value
        self.palm_body = self.model.body(PALM_BODY).id
        self.anchor_body = self.model.body(ANCHOR_BODY).id

    def forward(self, joints: dict[str, float]) -> None:
        self.data.qpos[:] = 0.0
        self.data.qpos[2], self.data.qpos[3] = INIT_HEIGHT_M, 1.0
        for name, value in {**self.default, **joints}.items():
            self.data.qpos[self.qpos_adr[name]] = value
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)  # mj_jac reads the COM-based frames

    def palm(self) -> tuple[np.ndarray, np.ndarray]:
        """The palm centre [m] and the palm body's rotation matrix, world = env frame."""
        rotation = self.data.xmat[self.palm_body].reshape(3, 3)
        return self.data.xpos[self.palm_body] + rotation @ np.array(PALM_OFFSET_M), rotation

    def body_pose(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        """Position and quaternion (x, y, z, w)."""
        w, x, y, z = self.data.xquat[body]
        return self.data.xpos[body].copy(), np.array([x, y, z, w])

    def solve_palm(self, target_m: np.ndarray, joints: dict[str, float], iterations: int = 600) -> dict[str, float]:
        """Right-arm angles that put the palm centre at `target_m` with the fingers pointing forward (+x) and the
        thumb to the left (+y), from `joints`; damped least squares, within the joint limits."""
        joints = dict(joints)
        jacp, jacr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))
        dofs = [self.dof_adr[n] for n in ARM_JOINTS]
        for _ in range(iterations):
            self.forward(joints)
            palm, rotation = self.palm()
            position_error = target_m - palm
            rotation_error = 0.5 * (np.cross(rotation[:, 0], [1, 0, 0]) + np.cross(rotation[:, 1], [0, 1, 0]))
            mujoco.mj_jac(self.model, self.data, jacp, jacr, palm, self.palm_body)
            jac = np.vstack([jacp[:, dofs], ROTATION_WEIGHT * jacr[:, dofs]])
            error = np.concatenate([position_error, ROTATION_WEIGHT * rotation_error])
            step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-3 * np.eye(6), error)
            for name, delta in zip(ARM_JOINTS, step, strict=True):
                low, high = self.model.jnt_range[self.model.joint(name).id]
                joints[name] = float(np.clip(joints[name] + delta, low, high))
        self.forward(joints)
        miss = np.linalg.norm(target_m - self.palm()[0])
        if miss > 0.005:
            raise RuntimeError(f"inverse kinematics misses the palm target {target_m.tolist()} by {miss:.3f} m")
        return joints


def quat_from_matrix(rotation: np.ndarray) -> np.ndarray:
    wxyz = np.zeros(4)
    mujoco.mju_mat2Quat(wxyz, rotation.flatten())
    return np.array([*wxyz[1:], wxyz[0]])


def make_trajectory(kin: G1Kinematics, goal_xy_m: tuple[float, float]) -> Trajectory:
    cube = np.array(CUBE_START_POS_M)
    goal = cube + np.array([*goal_xy_m, 0.0])
    lean = {"waist_pitch_joint": WAIST_PITCH_REACHING_RAD}
    start = {n: kin.default[n] for n in TRACKED_JOINTS}
    pre_grasp = kin.solve_palm(cube + PRE_GRASP_OFFSET_M, {**start, **lean})
    grasp = kin.solve_palm(cube, pre_grasp)
    closed = {**grasp, **HAND_CLOSED}
    lifted = {**kin.solve_palm(cube + [0, 0, LIFT_M], closed), **HAND_CLOSED}
    over_goal = {**kin.solve_palm(goal + [0, 0, LIFT_M], lifted), **HAND_CLOSED}
    at_goal = {**kin.solve_palm(goal, over_goal), **HAND_CLOSED}
    released = {**at_goal, **{n: 0.0 for n in HAND_CLOSED}}
    pulled_back = kin.solve_palm(goal + PRE_GRASP_OFFSET_M, released)
    keyframes = [  # (time [s], phase from here to the next keyframe, joints)
        (0.0, "approach", start), (1.5, "approach", pre_grasp), (3.0, "grasp", grasp), (3.5, "carry", closed),
        (4.5, "carry", lifted), (5.5, "carry", over_goal), (6.3, "release", at_goal), (6.8, "retract", released),
        (7.3, "retract", pulled_back), (7.8, "retract", start)]

    times = np.arange(0.0, keyframes[-1][0] + 1e-9, FRAME_STEP_S)
    rows = {key: [] for key in ("phase", "joint_pos", "object_pos_m", "object_quat_xyzw", "anchor_pos_m",
                                "anchor_quat_xyzw")}
    grasp_palm = None
    cube_pos, cube_rotation = cube, np.eye(3)  # at rest until carried; where it was put down after that
    for t in times:
        k = min(np.searchsorted([kf[0] for kf in keyframes], t, side="right") - 1, len(keyframes) - 2)
        (t0, phase, q0), (t1, _, q1) = keyframes[k], keyframes[k + 1]
        u = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
        s = u * u * (3.0 - 2.0 * u)
        joints = {n: (1.0 - s) * q0[n] + s * q1[n] for n in TRACKED_JOINTS}
        kin.forward(joints)
        palm, palm_rotation = kin.palm()
        if phase == "carry":  # the cube keeps the pose relative to the palm it had when the grasp ended
            if grasp_palm is None:
                grasp_palm = palm.copy(), palm_rotation.copy()
            relative = grasp_palm[1].T @ (cube - grasp_palm[0])
            cube_pos, cube_rotation = palm + palm_rotation @ relative, palm_rotation @ grasp_palm[1].T
        rows["phase"].append(PHASES.index(phase))
        rows["joint_pos"].append([joints[n] for n in TRACKED_JOINTS])
        rows["object_pos_m"].append(cube_pos)
        rows["object_quat_xyzw"].append(quat_from_matrix(cube_rotation))
        anchor_pos, anchor_quat = kin.body_pose(kin.anchor_body)
        rows["anchor_pos_m"].append(anchor_pos)
        rows["anchor_quat_xyzw"].append(anchor_quat)
    return Trajectory(joint_names=TRACKED_JOINTS, anchor_body=ANCHOR_BODY, time_s=times,
                      **{key: np.asarray(value) for key, value in rows.items()})


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(SHIPPED_TRAJECTORIES_DIR), help="output folder")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    kin = G1Kinematics()
    for name, (goal_xy_m, description) in GOALS_M.items():
        path = out / f"{name}.yaml"
        write_trajectory(path, make_trajectory(kin, goal_xy_m),
                         f"{description} (scripts/make_pick_place_trajectories.py)")
        print(f"[agile] {path}")


if __name__ == "__main__":
    main()
