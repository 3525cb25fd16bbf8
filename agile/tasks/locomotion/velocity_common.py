"""Blocks shared by the velocity tasks (identical in AGILE's T1 and G1 configs), built once here."""

from __future__ import annotations

import math

from agile.rl_env import mdp
from agile.rl_env.managers import CurrTerm, DoneTerm, EventTerm, ObsGroup, ObsTerm, SceneEntityCfg, Unoise
from agile.utils.config import configclass


def velocity_command_cfg() -> mdp.UniformNullVelocityCommandCfg:
    """vx, vy ±0.5 m/s, wz ±1 rad/s; resampled every 8-12 s; a quarter of the envs stand still."""
    return mdp.UniformNullVelocityCommandCfg(
        resampling_time_range_s=(8.0, 12.0), rel_standing_envs=0.25, min_vel_norm=0.1,
        ranges=mdp.VelocityRangesCfg(lin_vel_x=(-0.5, 0.5), lin_vel_y=(-0.5, 0.5), ang_vel_z=(-1.0, 1.0)))


@configclass
class VelocityEventsCfg:
    """Resets and pushes of the velocity tasks (the domain randomisation arrives with the terrain issue)."""

    reset_base = EventTerm(
        func=mdp.reset_root_state_uniform, mode="reset",
        params={"pose_range": {"x": (-2.5, 2.5), "y": (-2.5, 2.5), "roll": (-math.radians(10), math.radians(10)),
                               "pitch": (-math.radians(10), math.radians(10)), "yaw": (-math.pi, math.pi)},
                "velocity_range": {"x": (-0.25, 0.25), "y": (-0.25, 0.25), "roll": (-0.5, 0.5),
                                   "pitch": (-0.5, 0.5), "yaw": (-0.5, 0.5)}})
    reset_robot_joints = EventTerm(
        func=mdp.reset_joints_by_scale, mode="reset",
        params={"position_range": (0.8, 1.2), "velocity_range": (-1.0, 1.0)})
    push_robot = EventTerm(
        func=mdp.push_by_setting_velocity, mode="interval", interval_range_s=(2.0, 5.0),
        params={"velocity_range": {"x": (-0.5, 0.5), "y": (-0.5, 0.5), "roll": (-0.25, 0.25),
                                   "pitch": (-0.25, 0.25), "yaw": (-0.25, 0.25)}})


@configclass
class VelocityPolicyObsCfg(ObsGroup):
    """What the policy sees: 5 steps of history, noisy, one tensor per term (AGILE's TD groups)."""

    concatenate_terms = False
    enable_corruption = True
    history_length = 5
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel, scale=0.2, noise=Unoise(-0.2, 0.2))
    projected_gravity = ObsTerm(func=mdp.projected_gravity, noise=Unoise(-0.05, 0.05))
    velocity_commands = ObsTerm(func=mdp.generated_commands, params={"command_name": "base_velocity"})
    controlled_joint_pos = ObsTerm(func=mdp.joint_pos_rel, noise=Unoise(-0.01, 0.01))
    controlled_joint_vel = ObsTerm(func=mdp.joint_vel_rel, scale=0.05, noise=Unoise(-1.5, 1.5))
    actions = ObsTerm(func=mdp.last_action)


def velocity_policy_obs_cfg(controlled: SceneEntityCfg) -> VelocityPolicyObsCfg:
    """The policy group, with the joint terms on the controlled joints."""
    cfg = VelocityPolicyObsCfg()
    cfg.controlled_joint_pos.params["asset_cfg"] = controlled
    cfg.controlled_joint_vel.params["asset_cfg"] = controlled
    return cfg


@configclass
class VelocityCriticObsCfg(ObsGroup):
    """What the critic sees: noise-free, with the base linear velocity and every joint."""

    velocity_commands = ObsTerm(func=mdp.generated_commands, params={"command_name": "base_velocity"})
    base_lin_vel = ObsTerm(func=mdp.base_lin_vel)
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel)
    projected_gravity = ObsTerm(func=mdp.projected_gravity)
    joint_pos = ObsTerm(func=mdp.joint_pos_rel)
    joint_vel = ObsTerm(func=mdp.joint_vel_rel, scale=0.1)
    actions = ObsTerm(func=mdp.last_action)


@configclass
class VelocityTerminationsCfg:
    # orientation on the root: on G1 a torso limit (the torso tilts with the controlled waist joints) ended
    # 100% of the early episodes and collapsed the policy's action noise (measured at iteration 50)
    time_out = DoneTerm(func=mdp.time_out, time_out=True)
    bad_orientation = DoneTerm(func=mdp.bad_orientation, params={"limit_angle_rad": math.radians(30.0)})
    illegal_base_height = DoneTerm(func=mdp.root_height_below_minimum, params={"minimum_height_m": 0.0})


def velocity_terminations_cfg(base_height_target_m: float) -> VelocityTerminationsCfg:
    """Time-out; root tilted beyond 30°; root more than 0.3 m below its target height."""
    cfg = VelocityTerminationsCfg()
    cfg.illegal_base_height.params["minimum_height_m"] = base_height_target_m - 0.3
    return cfg


@configclass
class ActionRateCurriculumCfg:
    action_rate = CurrTerm(func=mdp.update_reward_weight_step,
                           params={"reward_name": "action_rate", "start_step": 50_000, "num_steps": 100_000,
                                   "terminal_weight": 0.0})
    action_rate_rate = CurrTerm(func=mdp.update_reward_weight_step,
                                params={"reward_name": "action_rate_rate", "start_step": 60_000,
                                        "num_steps": 100_000, "terminal_weight": 0.0})


def action_rate_curriculum_cfg(action_rate_final: float, action_rate_rate_final: float) -> ActionRateCurriculumCfg:
    """Ramp the action-rate penalties from 50k (and 60k) env steps over 100k steps to their final weights."""
    cfg = ActionRateCurriculumCfg()
    cfg.action_rate.params["terminal_weight"] = action_rate_final
    cfg.action_rate_rate.params["terminal_weight"] = action_rate_rate_final
    return cfg
