"""Velocity-T1-v0: Booster T1 walks at commanded planar velocities, controlling its 12 leg joints.

AGILE `T1LowerVelocityEnvCfg` on flat ground. Terms needing terrain, contact sensors or domain
randomisation (collision, feet_slip, root_acc, illegal_ground_contact, DR events, terrain curriculum,
random arm actions) are absent until those components exist.
"""

from __future__ import annotations

import math

from agile.assets.booster_t1 import LEG_JOINTS, t1_robot_cfg
from agile.rl_env import ManagerBasedRLEnvCfg, mdp
from agile.rl_env.managers import RewTerm, SceneEntityCfg
from agile.sim import SimCfg, SolverCfg
from agile.tasks.locomotion.velocity_common import (VelocityCriticObsCfg, VelocityEventsCfg,
                                                   action_rate_curriculum_cfg, velocity_command_cfg,
                                                   velocity_policy_obs_cfg, velocity_terminations_cfg)
from agile.utils.config import configclass

LEGS = SceneEntityCfg("robot", joint_names=LEG_JOINTS)
FEET = SceneEntityCfg("robot", body_names=["left_foot_link", "right_foot_link"], preserve_order=True)
BASE_HEIGHT_TARGET_M = 0.65


@configclass
class CommandsCfg:
    base_velocity = velocity_command_cfg()


@configclass
class ActionsCfg:
    joint_pos = mdp.JointPositionActionCfg(joint_names=[LEG_JOINTS], scale=1.0, use_default_offset=True,
                                           clip=(-1.0, 1.0))


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
                          params={"target_height_m": BASE_HEIGHT_TARGET_M, "std": 0.1})
    # -- base
    orientation = RewTerm(func=mdp.flat_orientation_l2, weight=-5.0)
    lin_vel_z = RewTerm(func=mdp.lin_vel_z_l2, weight=-0.5)
    ang_vel_xy = RewTerm(func=mdp.ang_vel_xy_l2, weight=-0.5)
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
    feet_roll = RewTerm(func=mdp.feet_roll_l2, weight=-0.1, params={"asset_cfg": FEET})
    feet_yaw_diff = RewTerm(func=mdp.feet_yaw_diff_l2, weight=-0.2, params={"asset_cfg": FEET})
    feet_yaw_mean = RewTerm(func=mdp.feet_yaw_mean_vs_base, weight=-4.0, params={"asset_cfg": FEET})
    feet_distance = RewTerm(func=mdp.feet_distance_from_ref, weight=-0.2,
                            params={"asset_cfg": FEET, "ref_distance_m": 0.2})


@configclass
class T1VelocityEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 4096
    decimation = 4  # 50 Hz policy
    episode_length_s = 30.0
    sim = SimCfg(physics_dt_s=0.005, env_spacing_m=2.5,
                 solver=SolverCfg(iterations=10, ls_iterations=20, njmax=300, nconmax=64))
    robot = t1_robot_cfg()
    commands = CommandsCfg()
    actions = ActionsCfg()
    observations = ObservationsCfg()
    rewards = RewardsCfg()
    terminations = velocity_terminations_cfg(BASE_HEIGHT_TARGET_M)
    events = VelocityEventsCfg()
    curriculum = action_rate_curriculum_cfg(action_rate_final=-2.0,
                                            action_rate_rate_final=-1.0)
