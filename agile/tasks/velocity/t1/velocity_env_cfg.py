"""Velocity-T1-v0: Booster T1 walks at commanded planar velocities, controlling its 12 leg joints.

AGILE `T1LowerVelocityEnvCfg`: less-rough terrain (small boxes and random bumps up to 10 cm) with the
terrain curriculum, domain randomisation, pushes, and random head and arm motions the policy must walk with.
"""

from __future__ import annotations

from agile.assets.booster_t1 import LEG_JOINTS, t1_robot_cfg
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import RewTerm, SceneEntityCfg
from agile.sim.terrain import LESS_ROUGH_TERRAIN_CFG
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import (BASE_HEIGHT_SENSOR, CONTACT_SENSOR, VelocityCriticObsCfg,
                                                   random_upper_body_action_cfg, velocity_command_cfg,
                                                   velocity_curriculum_cfg, velocity_events_cfg,
                                                   velocity_policy_obs_cfg, velocity_scene_cfg,
                                                   velocity_sim_cfg,
                                                   velocity_terminations_cfg, uniform_root_reset)
from agile.utils.config import configclass

LEGS = SceneEntityCfg("robot", joint_names=LEG_JOINTS)
FOOT_BODIES = ["left_foot_link", "right_foot_link"]
FEET = SceneEntityCfg("robot", body_names=FOOT_BODIES, preserve_order=True)
FEET_CONTACT = SceneEntityCfg(CONTACT_SENSOR, body_names=FOOT_BODIES, preserve_order=True)
BASE_HEIGHT_TARGET_M = 0.65

# -- scene: the robot alone on the terrain, with the contact sensor and the base-height ray
SCENE = velocity_scene_cfg(t1_robot_cfg(), LESS_ROUGH_TERRAIN_CFG, base_body="Trunk",
                           sensed_bodies=["Trunk", "Waist", *FOOT_BODIES])


@configclass
class CommandsCfg:
    base_velocity = velocity_command_cfg()


@configclass
class ActionsCfg:
    joint_pos = mdp.JointPositionActionCfg(joint_names=[LEG_JOINTS], scale=1.0, use_default_offset=True,
                                           clip=(-1.0, 1.0))
    random_pos = random_upper_body_action_cfg(excluded_joints=[LEG_JOINTS, "Waist"])


@configclass
class ObservationsCfg:
    policy = velocity_policy_obs_cfg(LEGS)
    critic = VelocityCriticObsCfg()


@configclass
class RewardsCfg:
    # -- task
    termination_penalty = RewTerm(func=mdp.is_terminated, weight=-100.0)
    track_lin_vel_xy_exp = RewTerm(func=mdp.track_lin_vel_xy_exp, weight=5.0,
                                   params={"command_name": "base_velocity", "std": 0.2})
    track_ang_vel = RewTerm(func=mdp.track_ang_vel_z_exp, weight=5.0, params={"command_name": "base_velocity", "std": 0.2})
    base_height = RewTerm(func=mdp.base_height_exp, weight=2.0,
                          params={"target_height_m": BASE_HEIGHT_TARGET_M, "std": 0.1,
                                  "sensor_name": BASE_HEIGHT_SENSOR})
    # -- base
    orientation = RewTerm(func=mdp.flat_orientation_l2, weight=-5.0)
    lin_vel_z = RewTerm(func=mdp.lin_vel_z_l2, weight=-0.5)
    ang_vel_xy = RewTerm(func=mdp.ang_vel_xy_l2, weight=-0.5)
    root_acc = RewTerm(func=mdp.body_acc_l2, weight=-2.0e-5,
                       params={"asset_cfg": SceneEntityCfg("robot", body_names="Trunk")})
    collision = RewTerm(func=mdp.undesired_contacts, weight=-0.2,
                        params={"sensor_cfg": SceneEntityCfg(CONTACT_SENSOR, body_names="Trunk"),
                                "force_threshold_n": 1.0})
    # -- joints
    torques = RewTerm(func=mdp.joint_torques_l2, weight=-1.0e-4, params={"asset_cfg": LEGS})
    ankle_torques = RewTerm(func=mdp.joint_torques_l2, weight=-1.0e-4,
                            params={"asset_cfg": SceneEntityCfg("robot", joint_names=".*Ankle.*")})
    ankle_roll_torques = RewTerm(func=mdp.joint_torques_l2, weight=-2.0e-3,
                                 params={"asset_cfg": SceneEntityCfg("robot", joint_names=".*Ankle_Roll")})
    dof_vel = RewTerm(func=mdp.joint_vel_l2, weight=-2.0e-4)
    dof_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-1.0)
    dof_vel_limits = RewTerm(func=mdp.joint_vel_limits, weight=-1.0, params={"soft_ratio": 0.9})
    torque_limits = RewTerm(func=mdp.applied_torque_limits, weight=-0.01)
    # -- actions
    action_rate = RewTerm(func=mdp.action_rate_l2, weight=-0.5)
    action_rate_rate = RewTerm(func=mdp.action_rate_rate_l2, weight=-0.05)
    # -- feet
    feet_slip = RewTerm(func=mdp.feet_slip, weight=-0.1, params={"sensor_cfg": FEET_CONTACT, "asset_cfg": FEET})
    feet_roll = RewTerm(func=mdp.feet_roll_l2, weight=-0.1, params={"asset_cfg": FEET})
    feet_yaw_diff = RewTerm(func=mdp.feet_yaw_diff_l2, weight=-0.2, params={"asset_cfg": FEET})
    feet_yaw_mean = RewTerm(func=mdp.feet_yaw_mean_vs_base, weight=-4.0,
                            params={"feet_asset_cfg": FEET,
                                    "base_body_cfg": SceneEntityCfg("robot", body_names="Waist")})
    feet_distance = RewTerm(func=mdp.feet_distance_from_ref, weight=-0.2,
                            params={"asset_cfg": FEET, "ref_distance_m": 0.2})


@configclass
class T1VelocityEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 4096
    decimation = 4  # 50 Hz policy
    episode_length_s = 30.0
    scene = SCENE
    sim = velocity_sim_cfg(max_contacts_per_world=128)  # standing about 15, flailing up to 75
    commands = CommandsCfg()
    actions = ActionsCfg()
    observations = ObservationsCfg()
    rewards = RewardsCfg()
    terminations = velocity_terminations_cfg(BASE_HEIGHT_TARGET_M, trunk_bodies=["Trunk", "Waist"])
    events = velocity_events_cfg(base_body="Trunk", base_mass_add_kg=(-1.0, 3.0),
                                 base_com_range_m={"x": (-0.15, 0.15), "y": (-0.05, 0.05), "z": (-0.15, 0.15)},
                                 extremity_bodies=["left_hand_link", "right_hand_link", *FOOT_BODIES],
                                 reset_base=uniform_root_reset(xy_range_m=2.5))
    curriculum = velocity_curriculum_cfg(action_rate_final=-2.0, action_rate_rate_final=-1.0)
