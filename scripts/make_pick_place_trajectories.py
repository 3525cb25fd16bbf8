"""Write the shipped pick-and-place trajectories (agile/data/trajectories/*.yaml).

    python scripts/make_pick_place_trajectories.py                 # into agile/data/trajectories/
    python scripts/make_pick_place_trajectories.py --out /tmp/traj

Each trajectory is a few hand keyframes (raised above the table's near edge, beside the cube, around the cube,
lifted, over the goal, at the goal, pulled away, raised) solved by damped-least-squares inverse kinematics on the
right arm of the MuJoCo model of the G1 with hands (root fixed where the frozen lower body stands), with scripted
finger angles and a straight waist. Between keyframes the joints ease in and out (smoothstep); the cube rides with
the hand while it holds it. Frames are written every 0.1 s, which the loader interpolates linearly
(agile/motion/trajectory_file.py).

The grasp is a pinch from the cube's right side, the hand upright with its palm (+y of the wrist-yaw link, where
the thumb and the curling fingers point) facing the cube 2 cm off it: the thumb on the cube's near face, the middle
fingertip on its far face; the index finger closes just above the cube. Every frame is checked against the table
and the cube in MuJoCo (`check_clearance`): no hand geom enters the table, none touches the cube before the grasp,
and the closed thumb and middle finger press into it (their PD squeezes by the angle they are held short of the
reference). `scripts/replay_pick_place_reference.py --fixed_root --gravity_compensation` replays them in the task.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np

from agile.assets.tabletop import CUBE_EDGE_M, CUBE_START_POS_M, TABLE_FRONT_EDGE_X_M, TABLE_SIZE_M
from agile.assets.unitree_g1_with_hands import GRASP_POINT_M, PALM_BODY, g1_with_hands_robot_cfg
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
HAND_OPEN = {"right_hand_thumb_1_joint": 0.5}
"""Fingers straight, the thumb swung back (away from the fingers), so that it passes behind the cube [rad]."""
HAND_CLOSED = {"right_hand_thumb_1_joint": -0.2, "right_hand_thumb_2_joint": -0.2, "right_hand_middle_0_joint": 1.2,
               "right_hand_middle_1_joint": 0.7, "right_hand_index_0_joint": 1.2, "right_hand_index_1_joint": 0.7}
"""Around the 6 cm cube [rad]. The right thumb closes toward negative thumb_1 (range -1.05..0.72; +0.5 swings it
away from the fingers). Measured in MuJoCo with the cube at `OBJECT_IN_HAND_M`: the thumb meets the cube at
thumb_1 0.02 (thumb_2 -0.2), the middle fingertip at middle_0 1.0 / middle_1 0.6. These angles are 0.1-0.2 rad
further, so that the soft finger PD (kp 4 N·m/rad) squeezes with 0.4-0.7 N·m: 8-9 N from the thumb and 9 N from
the middle fingertip, measured in the replay, against the cube's 1 N weight (friction 1). With AGILE V1.3's Dex3 finger motor (kp 2, 0.76 N·m;
agile_tasks.md section 4) the fixed-root replay lifts it as well (2 of 2, 10.4-10.6 cm)."""
OBJECT_IN_HAND_M = np.array(GRASP_POINT_M)
"""The held cube's centre in the wrist-yaw link's frame: the hand's grasp point (see its docstring)."""
STANDING_ROOT_POS_M = np.array([-0.03, 0.0, 0.735])
STANDING_ROOT_PITCH_RAD = -0.05
"""Where the frozen lower body holds the pelvis standing still (command [0, 0, 0, 0.72], arms at their defaults),
measured in this scene on CPU: 2.5 cm below and 3 cm behind the spawn pose (0, 0, 0.76), tilted back 0.05 rad.
The reference is solved for the robot as it stands. No scripted waist lean: the soft waist (kp 28.5 N·m/rad)
already bends forward 0.2-0.4 rad under the reaching arm."""
FRAME_STEP_S = 0.1
ROTATION_WEIGHT = 0.1
"""How much the inverse kinematics trades hand position [m] for the hand's orientation [rad]: a soft preference."""
LIFT_M = 0.12
BESIDE_CUBE_M = np.array([0.0, -0.05, 0.01])
"""The held point's keyframe before the grasp: 5 cm right of the cube (the palm's side) and 1 cm above it."""
AWAY_FROM_CUBE_M = np.array([0.0, -0.02, 0.06])
"""The held point's keyframe after the release: the open hand up and away from the cube put down."""
RAISED_HAND_M = np.array([TABLE_FRONT_EDGE_X_M - 0.16, CUBE_START_POS_M[1] - 0.08, TABLE_SIZE_M[2] + 0.11])
"""The held point's keyframe on the way from the hanging arm to the table and back: in front of the table's near
edge (the fingers reach 11 cm ahead of it) and the hand's lower edge 6 cm above the table top."""
TABLE_CLEARANCE_M = 0.001
"""The deepest a hand geom may enter the table in any frame [m] (contact distances of convex meshes)."""
GOALS_M = {  # name: (cube goal xy offset from its start [m], description)
    "pick_place_left": ((0.0, 0.15), "pick the cube up and put it down 15 cm to the left"),
    "pick_place_near_left": ((0.0, 0.08), "pick the cube up and put it down 8 cm to the left"),
    "pick_place_right": ((-0.02, -0.10), "pick the cube up and put it down 10 cm to the right, 2 cm nearer"),
}


class G1Kinematics:
    """MuJoCo model of the G1 with hands, root fixed where it stands, with the table and a posable cube; forward and
    inverse kinematics and the hand's contacts with the table and the cube."""

    def __init__(self):
        cfg = g1_with_hands_robot_cfg()
        spec = mujoco.MjSpec.from_file(cfg.model_file)
        table_half_m = np.array(TABLE_SIZE_M) / 2
        spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, size=table_half_m,
                                pos=[TABLE_FRONT_EDGE_X_M + table_half_m[0], 0.0, table_half_m[2]])
        cube = spec.worldbody.add_body(name="cube", mocap=True)
        cube.add_geom(name="cube", type=mujoco.mjtGeom.mjGEOM_BOX, size=[CUBE_EDGE_M / 2] * 3)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.joint_names = [self.model.joint(i).name for i in range(1, self.model.njnt)]  # after the free root
        self.qpos_adr = {n: self.model.joint(n).qposadr[0] for n in self.joint_names}
        self.dof_adr = {n: self.model.joint(n).dofadr[0] for n in self.joint_names}
        self.default = {n: 0.0 for n in self.joint_names}
        for i, value in resolve_values(cfg.init_joint_pos, self.joint_names).items():
            self.default[self.joint_names[i]] = value
        self.palm_body = self.model.body(PALM_BODY).id
        self.anchor_body = self.model.body(ANCHOR_BODY).id
        self.hand_bodies = {i for i in range(self.model.nbody) if self.model.body(i).name.startswith("right_hand_")}
        self.hand_bodies.add(self.palm_body)
        self.table_geom, self.cube_geom = self.model.geom("table").id, self.model.geom("cube").id

    def forward(self, joints: dict[str, float], cube_pos_m=(0.0, 0.0, -1.0), cube_rotation=np.eye(3)) -> None:
        self.data.qpos[:] = 0.0
        self.data.qpos[:3] = STANDING_ROOT_POS_M
        self.data.qpos[3:7] = [np.cos(STANDING_ROOT_PITCH_RAD / 2), 0.0, np.sin(STANDING_ROOT_PITCH_RAD / 2), 0.0]
        for name, value in {**self.default, **joints}.items():
            self.data.qpos[self.qpos_adr[name]] = value
        self.data.mocap_pos[0] = cube_pos_m
        mujoco.mju_mat2Quat(self.data.mocap_quat[0], np.asarray(cube_rotation).flatten())
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)  # mj_jac reads the COM-based frames

    def hand_point(self, point_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A point given in the palm body's (wrist-yaw link's) frame, and that frame's rotation matrix, world = env
        frame."""
        rotation = self.data.xmat[self.palm_body].reshape(3, 3)
        return self.data.xpos[self.palm_body] + rotation @ point_m, rotation

    def body_pose(self, body: int) -> tuple[np.ndarray, np.ndarray]:
        """Position and quaternion (x, y, z, w)."""
        w, x, y, z = self.data.xquat[body]
        return self.data.xpos[body].copy(), np.array([x, y, z, w])

    def contacts(self) -> dict[str, float]:
        """{"table"|"cube": the deepest any right-hand geom enters it [m]} after `forward`."""
        mujoco.mj_collision(self.model, self.data)
        deepest = {"table": 0.0, "cube": 0.0}
        for contact in self.data.contact[:self.data.ncon]:
            for other, name in ((self.table_geom, "table"), (self.cube_geom, "cube")):
                geom = {contact.geom1, contact.geom2} - {other}
                if len(geom) == 1 and self.model.geom_bodyid[geom.pop()] in self.hand_bodies:
                    deepest[name] = max(deepest[name], -contact.dist)
        return deepest

    def solve(self, target_m: np.ndarray, joints: dict[str, float], point_m: np.ndarray = OBJECT_IN_HAND_M,
              iterations: int = 600) -> dict[str, float]:
        """Right-arm angles that put `point_m` (palm body frame; the held cube's centre) at `target_m` with the
        fingers pointing forward (+x) and the thumb to the left (+y), from `joints`; damped least squares, within the
        joint limits."""
        joints = dict(joints)
        jacp, jacr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))
        dofs = [self.dof_adr[n] for n in ARM_JOINTS]
        for _ in range(iterations):
            self.forward(joints)
            point, rotation = self.hand_point(point_m)
            position_error = target_m - point
            rotation_error = 0.5 * (np.cross(rotation[:, 0], [1, 0, 0]) + np.cross(rotation[:, 1], [0, 1, 0]))
            mujoco.mj_jac(self.model, self.data, jacp, jacr, point, self.palm_body)
            jac = np.vstack([jacp[:, dofs], ROTATION_WEIGHT * jacr[:, dofs]])
            error = np.concatenate([position_error, ROTATION_WEIGHT * rotation_error])
            step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-3 * np.eye(6), error)
            for name, delta in zip(ARM_JOINTS, step, strict=True):
                low, high = self.model.jnt_range[self.model.joint(name).id]
                joints[name] = float(np.clip(joints[name] + delta, low, high))
        self.forward(joints)
        miss = np.linalg.norm(target_m - self.hand_point(point_m)[0])
        if miss > 0.005:
            raise RuntimeError(f"inverse kinematics misses the hand target {target_m.tolist()} by {miss:.3f} m")
        return joints


def quat_from_matrix(rotation: np.ndarray) -> np.ndarray:
    wxyz = np.zeros(4)
    mujoco.mju_mat2Quat(wxyz, rotation.flatten())
    return np.array([*wxyz[1:], wxyz[0]])


def make_trajectory(kin: G1Kinematics, goal_xy_m: tuple[float, float], name: str = "") -> Trajectory:
    cube = np.array(CUBE_START_POS_M)
    goal = cube + np.array([*goal_xy_m, 0.0])
    start = {n: kin.default[n] for n in TRACKED_JOINTS}
    raised = {**kin.solve(RAISED_HAND_M, start), **HAND_OPEN}
    beside = {**kin.solve(cube + BESIDE_CUBE_M, raised), **HAND_OPEN}
    grasp = {**kin.solve(cube, beside), **HAND_OPEN}
    closed = {**grasp, **HAND_CLOSED}
    lifted = {**kin.solve(cube + [0, 0, LIFT_M], closed), **HAND_CLOSED}
    over_goal = {**kin.solve(goal + [0, 0, LIFT_M], lifted), **HAND_CLOSED}
    at_goal = {**kin.solve(goal, over_goal), **HAND_CLOSED}
    released = {**at_goal, **{n: 0.0 for n in HAND_CLOSED}, **HAND_OPEN}
    pulled_away = {**kin.solve(goal + AWAY_FROM_CUBE_M, released), **HAND_OPEN}
    keyframes = [  # (time [s], phase from here to the next keyframe, joints)
        (0.0, "approach", start), (1.0, "approach", raised), (2.0, "approach", beside), (3.0, "grasp", grasp),
        (3.5, "carry", closed), (4.5, "carry", lifted), (5.5, "carry", over_goal), (6.3, "release", at_goal),
        (6.8, "retract", released), (7.1, "retract", pulled_away), (7.5, "retract", raised), (7.8, "retract", start)]

    times = np.arange(0.0, keyframes[-1][0] + 1e-9, FRAME_STEP_S)
    rows = {key: [] for key in ("phase", "joint_pos", "object_pos_m", "object_quat_xyzw", "anchor_pos_m",
                                "anchor_quat_xyzw")}
    grasp_hand = None
    cube_pos, cube_rotation = cube, np.eye(3)  # at rest until carried; where it was put down after that
    for t in times:
        k = min(np.searchsorted([kf[0] for kf in keyframes], t, side="right") - 1, len(keyframes) - 2)
        (t0, phase, q0), (t1, _, q1) = keyframes[k], keyframes[k + 1]
        u = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
        s = u * u * (3.0 - 2.0 * u)
        joints = {n: (1.0 - s) * q0[n] + s * q1[n] for n in TRACKED_JOINTS}
        kin.forward(joints)
        hand, hand_rotation = kin.hand_point(np.zeros(3))
        if phase == "carry":  # the cube keeps the pose relative to the hand it had when the grasp ended
            if grasp_hand is None:
                grasp_hand = hand.copy(), hand_rotation.copy()
            relative = grasp_hand[1].T @ (cube - grasp_hand[0])
            cube_pos, cube_rotation = hand + hand_rotation @ relative, hand_rotation @ grasp_hand[1].T
        check_clearance(kin, joints, cube_pos, cube_rotation, phase, f"{name} at {t:.1f} s")
        kin.forward(joints)
        rows["phase"].append(PHASES.index(phase))
        rows["joint_pos"].append([joints[n] for n in TRACKED_JOINTS])
        rows["object_pos_m"].append(cube_pos)
        rows["object_quat_xyzw"].append(quat_from_matrix(cube_rotation))
        anchor_pos, anchor_quat = kin.body_pose(kin.anchor_body)
        rows["anchor_pos_m"].append(anchor_pos)
        rows["anchor_quat_xyzw"].append(anchor_quat)
    return Trajectory(joint_names=TRACKED_JOINTS, anchor_body=ANCHOR_BODY, time_s=times,
                      **{key: np.asarray(value) for key, value in rows.items()})


def check_clearance(kin: G1Kinematics, joints: dict[str, float], cube_pos_m: np.ndarray, cube_rotation: np.ndarray,
                    phase: str, where: str) -> None:
    """The hand never enters the table, touches the cube only from the grasp to the release, and the closed hand
    presses into it (a reference the hand cannot follow through the table is no reference)."""
    kin.forward(joints, cube_pos_m, cube_rotation)
    depth = kin.contacts()
    if depth["table"] > TABLE_CLEARANCE_M:
        raise RuntimeError(f"{where}: the hand enters the table by {depth['table'] * 1000:.1f} mm")
    if phase == "approach" and depth["cube"] > 0.0:
        raise RuntimeError(f"{where}: the hand touches the cube before the grasp ({depth['cube'] * 1000:.1f} mm)")
    if phase == "carry" and depth["cube"] <= 0.0:
        raise RuntimeError(f"{where}: the closed hand does not touch the cube it carries")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(SHIPPED_TRAJECTORIES_DIR), help="output folder")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    kin = G1Kinematics()
    for name, (goal_xy_m, description) in GOALS_M.items():
        path = out / f"{name}.yaml"
        write_trajectory(path, make_trajectory(kin, goal_xy_m, name),
                         f"{description} (scripts/make_pick_place_trajectories.py)")
        print(f"[agile] {path}")


if __name__ == "__main__":
    main()
