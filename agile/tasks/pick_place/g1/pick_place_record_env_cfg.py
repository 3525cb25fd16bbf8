"""PickPlace-G1-Record-v0: PickPlace-G1-v0 with a head-height RGB camera, for recording demonstrations.

AGILE `G1PickPlaceTrackingEnvCfgRecord`: a trained PickPlace policy acts as in PickPlace-G1-v0 (its privileged
`policy` group is unchanged), and `agile record` writes what a camera-based policy would see and do (the `record`
group below, and each action term's `demonstration_action`: the 17 absolute upper-body joint targets and the 4-D
lower-body command) as a GR00T LeRobot dataset. Episodes follow the reference from its first frame; the camera
renders every env's own world.
"""

from __future__ import annotations

import dataclasses

from agile.assets.unitree_g1_with_hands import WAIST_JOINTS
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import ObsGroup, ObsTerm, SceneEntityCfg
from agile.sim.scene_cfg import CameraCfg
from agile.tasks.pick_place import mdp
from agile.tasks.pick_place.g1.pick_place_env_cfg import (UPPER_BODY, PolicyObsCfg, commands_from_first_frame,
                                                          pick_place_env_cfg, pick_place_scene_cfg)
from agile.utils.config import configclass

FRONT_CAMERA = "front_cam"
FRONT_CAMERA_CFG = CameraCfg(
    entity="robot", body_name="torso_link", offset_pos_m=(0.1, 0.0, 0.45),
    # AGILE gives the offset and the ROS optical convention; the tilt is ours: 50 degrees down puts the cube
    # (60 degrees below the camera at the start), the right hand and the table's far edge (35 degrees) in view
    pitch_down_rad=0.87,
    width=640, height=480, fx=375.15, fy=374.93, cx=317.8, cy=248.4, calibration_size_px=(640, 480))
"""AGILE's `front_cam`: the OAK-D's pinhole intrinsics, 0.1 m ahead of and 0.45 m above the torso link."""
LEGS_AND_WAIST = SceneEntityCfg("robot", joint_names=[".*_hip_.*_joint", ".*_knee_joint", ".*_ankle_.*_joint",
                                                      *WAIST_JOINTS])


@configclass
class RecordObsCfg(ObsGroup):
    """What a demonstration records each control step, noise-free. `observation.state` is the vector terms in this
    order (AGILE's slices: base angular velocity 0:3, base linear velocity 3:6, upper-body joints 6:23, leg and
    waist joint velocities 23:38), plus the object's pose (38:45), which AGILE does not record; `image` is the
    video."""

    concatenate_terms = False
    image = ObsTerm(func=mdp.camera_rgb, params={"sensor_name": FRONT_CAMERA})
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel)
    base_lin_vel = ObsTerm(func=mdp.base_lin_vel)
    joint_pos = ObsTerm(func=mdp.joint_pos_rel, params={"asset_cfg": UPPER_BODY})
    joint_vel = ObsTerm(func=mdp.joint_vel_rel, scale=0.1, params={"asset_cfg": LEGS_AND_WAIST})
    object_pose = ObsTerm(func=mdp.root_pose_env, params={"asset_cfg": SceneEntityCfg("object")})


@configclass
class ObservationsCfg:
    policy = PolicyObsCfg()
    record = RecordObsCfg()


def pick_place_record_env_cfg() -> ManagerBasedRLEnvCfg:
    """PickPlace-G1-v0 with the camera and the `record` group; every episode from the reference's first frame;
    4 envs by default. The step is not graph-captured: the camera renders between steps."""
    return dataclasses.replace(pick_place_env_cfg(), num_envs=4, capture_step=False,
                               scene=pick_place_scene_cfg(cameras={FRONT_CAMERA: FRONT_CAMERA_CFG}),
                               commands=commands_from_first_frame(), observations=ObservationsCfg())
