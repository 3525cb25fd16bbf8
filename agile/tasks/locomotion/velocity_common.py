"""Blocks shared by the velocity tasks (identical in AGILE's T1 and G1 configs), built once here."""

from __future__ import annotations

import math

from agile.rl_env import mdp
from agile.rl_env.managers import EventTerm
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
