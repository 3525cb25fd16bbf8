"""Observation terms: functions (env, **params) -> (N, D) tensors (an image term: (N, H, W, 3))."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg

__all__ = ["base_ang_vel", "base_height_above_ground", "base_height_from_sensor", "base_lin_vel", "camera_rgb",
           "contact_force_norm", "generated_commands", "height_scan", "height_scan_feet", "joint_pos",
           "joint_pos_rel", "joint_vel_rel", "last_action", "projected_gravity", "root_pose_env"]



def base_lin_vel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Root linear velocity in the root frame [m/s]."""
    return env.scene[asset_cfg.name].root_lin_vel_b


def base_ang_vel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Root angular velocity in the root frame [rad/s]."""
    return env.scene[asset_cfg.name].root_ang_vel_b


def projected_gravity(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Unit gravity direction in the root frame."""
    return env.scene[asset_cfg.name].projected_gravity_b


def generated_commands(env, command_name: str) -> torch.Tensor:
    return env.command_manager.get_command(command_name)


def joint_pos_rel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Joint positions relative to the default pose [rad]."""
    robot = env.scene[asset_cfg.name]
    return robot.joint_pos[:, asset_cfg.joint_ids] - robot.default_joint_pos[:, asset_cfg.joint_ids]


def joint_pos(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return env.scene[asset_cfg.name].joint_pos[:, asset_cfg.joint_ids]


def joint_vel_rel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    robot = env.scene[asset_cfg.name]
    return robot.joint_vel[:, asset_cfg.joint_ids] - robot.default_joint_vel[:, asset_cfg.joint_ids]


def last_action(env, action_name: str | None = None) -> torch.Tensor:
    """The last policy action (all terms, or one action term's slice)."""
    manager = env.action_manager
    if action_name is None:
        return manager.action
    start = 0
    for name, term in manager.terms.items():
        if name == action_name:
            return manager.action[:, start:start + term.action_dim]
        start += term.action_dim
    raise KeyError(f"no action term '{action_name}'. Terms: {manager.active_terms}")


def contact_force_norm(env, sensor_cfg: SceneEntityCfg) -> torch.Tensor:
    """|net contact force| of the selected sensor bodies at the last physics step [N], (N, B)."""
    return torch.norm(env.scene[sensor_cfg.name].net_forces_w[:, sensor_cfg.body_ids], dim=-1)


def base_height_above_ground(env, asset_cfg: SceneEntityCfg = ROBOT, sensor_name: str | None = None) -> torch.Tensor:
    """(N,) root height [m] above z=0 without a sensor, above the mean terrain height under the height
    scanner `sensor_name` with one (AGILE's terrain-adjusted base height; the env updates the scanner)."""
    height = env.scene[asset_cfg.name].root_pos_w[:, 2]
    if sensor_name is None:
        return height
    return height - env.scene[sensor_name].hit_z_m.mean(dim=1)


def height_scan(env, sensor_name: str, offset_m: float = 0.5,
                clip_m: tuple[float, float] = (-1.0, 1.0)) -> torch.Tensor:
    """(N, R) sensor height minus the terrain height under each ray, minus `offset_m` (Isaac Lab's
    `height_scan`: about 0 for a base `offset_m` above flat ground), clipped to `clip_m` [m]."""
    scanner = env.scene[sensor_name]
    scan = scanner.pos_w[:, 2:3] - scanner.hit_z_m - offset_m
    return scan.clamp(clip_m[0], clip_m[1])


def base_height_from_sensor(env, sensor_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """(N, 1) root height above the mean terrain height under the height scanner `sensor_name` [m] (AGILE's
    `base_height_from_sensor`, and what its `base_height_from_command` reads off the command term)."""
    return base_height_above_ground(env, asset_cfg, sensor_name).unsqueeze(1)


def height_scan_feet(env, left_sensor_name: str, right_sensor_name: str) -> torch.Tensor:
    """(N, 2R) the height of each foot above the terrain under each ray of its scanner [m]: the left foot's R
    rays, then the right foot's, each in its scanner's grid order. Clip it in the ObsTerm (AGILE: ±1 m).

    AGILE subtracts the hits from its ray caster's origin, 20 m above the foot, so every value clips to 1; here
    the scan is relative to the foot, as its docstring says."""
    scans = []
    for name in (left_sensor_name, right_sensor_name):
        scanner = env.scene[name]
        scans.append(scanner.pos_w[:, 2:3] - scanner.hit_z_m)
    return torch.cat(scans, dim=1)


def root_pose_env(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """(N, 7) an entity's root position in its env's frame [m] (origin at the env's, world axes) and its
    orientation (x, y, z, w), e.g. the object of a pick-and-place recording."""
    entity = env.scene[asset_cfg.name]
    return torch.cat((entity.root_pos_env, entity.root_quat_w), dim=-1)


def camera_rgb(env, sensor_name: str) -> torch.Tensor:
    """(N, H, W, 3) uint8: what the scene camera `sensor_name` sees (a copy, so that a later render does not change
    an observation already returned). Keep it in a group of separate terms (`concatenate_terms=False`)."""
    return env.scene[sensor_name].rgb(env.sim.state).clone()
