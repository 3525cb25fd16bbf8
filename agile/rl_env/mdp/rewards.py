"""Reward terms: functions (env, **params) -> (N,) tensors. The weight sets the sign; penalties return costs."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.rl_env.mdp.observations import base_height_above_ground
from agile.utils.math import quat_rotate_inverse, wrap_to_pi, yaw_from_quat

__all__ = ["action_l2", "action_rate_l2", "action_rate_rate_l2", "ang_vel_xy_l2", "applied_torque_limits",
           "base_height_exp", "body_acc_l2", "body_ang_vel_l2", "body_projected_gravity", "equal_foot_force",
           "feet_air_time", "feet_air_time_positive_biped", "feet_distance_from_ref", "feet_roll_l2", "feet_slip",
           "feet_stumble", "feet_yaw_diff_l2", "feet_yaw_mean_vs_base", "filtered_contact",
           "flat_body_orientation_exp", "flat_orientation_l2", "illegal_contact", "impact_velocity_l1", "is_alive",
           "is_terminated", "is_terminated_term", "joint_acc_l2", "joint_deviation_l1", "joint_deviation_l2",
           "joint_pos_limits", "joint_torques_l2", "joint_vel_l2", "joint_vel_limits", "jumping", "lin_vel_z_l2",
           "object_body_distance_exp", "object_is_lifted", "track_ang_vel_z_exp", "track_lin_vel_xy_exp",
           "undesired_contacts"]



# -- task -----------------------------------------------------------------------------------------

def is_terminated(env) -> torch.Tensor:
    """1 for episodes that ended by a failure (not a time-out)."""
    return env.termination_manager.terminated.float()


def is_alive(env) -> torch.Tensor:
    """1 for envs whose episode goes on (no failure this step)."""
    return (~env.termination_manager.terminated).float()


def track_lin_vel_xy_exp(env, std: float, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-|v_cmd,xy - v_xy|² / std²), velocities in the root frame."""
    robot = env.scene[asset_cfg.name]
    command = env.command_manager.get_command(command_name)
    error = torch.sum(torch.square(command[:, :2] - robot.root_lin_vel_b[:, :2]), dim=1)
    return torch.exp(-error / std**2)


def track_ang_vel_z_exp(env, std: float, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(w_cmd,z - w_z)² / std²), root frame."""
    robot = env.scene[asset_cfg.name]
    command = env.command_manager.get_command(command_name)
    error = torch.square(command[:, 2] - robot.root_ang_vel_b[:, 2])
    return torch.exp(-error / std**2)


def base_height_exp(env, target_height_m: float, std: float, asset_cfg: SceneEntityCfg = ROBOT,
                    sensor_name: str | None = None) -> torch.Tensor:
    """exp(-(h - h_target)² / std²) with h the root height above the ground (`base_height_above_ground`)."""
    height = base_height_above_ground(env, asset_cfg, sensor_name)
    return torch.exp(-torch.square(height - target_height_m) / std**2)


# -- orientation and base motion --------------------------------------------------------------------

def body_projected_gravity(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """(N, B, 3) gravity direction in the frames of the selected bodies (root if none selected)."""
    robot = env.scene[asset_cfg.name]
    if asset_cfg.body_names is None:
        return robot.projected_gravity_b.unsqueeze(1)
    quat = robot.body_pose_w[:, asset_cfg.body_ids, 3:7]
    gravity = robot.gravity_dir_w.unsqueeze(1).expand(-1, quat.shape[1], -1)
    return quat_rotate_inverse(quat, gravity)


def flat_orientation_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Squared xy of the gravity direction in the body frame (0 when upright), summed over bodies."""
    return torch.sum(torch.square(body_projected_gravity(env, asset_cfg)[..., :2]), dim=(1, 2))


def flat_body_orientation_exp(env, std_rad: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-Σ_bodies |g_xy|² / std²) (AGILE: the bodies' squared tilts add up inside one kernel);
    |g_xy| ≈ tilt angle for small tilts."""
    g_xy = body_projected_gravity(env, asset_cfg)[..., :2]
    return torch.exp(-torch.sum(torch.square(g_xy), dim=(1, 2)) / std_rad**2)


def lin_vel_z_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.square(env.scene[asset_cfg.name].root_lin_vel_b[:, 2])


def ang_vel_xy_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].root_ang_vel_b[:, :2]), dim=1)


def body_acc_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Sum over the selected bodies (all if none selected) of |COM linear acceleration|² [m²/s⁴] plus
    |angular acceleration|² [rad²/s⁴], each the velocity change over the env step (gravity not included: 0 at
    rest), clamped at 1e6 as AGILE does so that one violent contact cannot swamp the return."""
    robot = env.scene[asset_cfg.name]
    squared = torch.sum(torch.square(robot.body_lin_acc_w[:, asset_cfg.body_ids]), dim=(1, 2))
    squared += torch.sum(torch.square(robot.body_ang_acc_w[:, asset_cfg.body_ids]), dim=(1, 2))
    return torch.clamp(squared, max=1e6)


# -- joint regularisation ---------------------------------------------------------------------------

def joint_torques_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].applied_torque[:, asset_cfg.joint_ids]), dim=1)


def joint_vel_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].joint_vel[:, asset_cfg.joint_ids]), dim=1)


def joint_acc_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].joint_acc[:, asset_cfg.joint_ids]), dim=1)


def joint_deviation_l1(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    return torch.sum(torch.abs(robot.joint_pos[:, ids] - robot.default_joint_pos[:, ids]), dim=1)


def joint_deviation_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Σ (q - q_default)² over the selected joints [rad²]."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    return torch.sum(torch.square(robot.joint_pos[:, ids] - robot.default_joint_pos[:, ids]), dim=1)


def joint_pos_limits(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Sum of how far joints are outside their soft position limits [rad] (Isaac Lab: the hard limits shrunk
    by `ArticulationCfg.soft_joint_pos_limit_factor`)."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    pos = robot.joint_pos[:, ids]
    limits = robot.soft_joint_pos_limits[:, ids]
    below = (limits[..., 0] - pos).clamp(min=0.0)
    above = (pos - limits[..., 1]).clamp(min=0.0)
    return torch.sum(below + above, dim=1)


def joint_vel_limits(env, soft_ratio: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Sum over joints of the speed above soft_ratio·limit, each clipped to 1 rad/s (Isaac Lab)."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    excess = robot.joint_vel[:, ids].abs() - robot.joint_vel_limit[:, ids] * soft_ratio
    return torch.sum(excess.clamp(min=0.0, max=1.0), dim=1)


def applied_torque_limits(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Sum of |computed - applied| torque: how much the effort limits clip the actuators [N·m]."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    return torch.sum(torch.abs(robot.computed_torque[:, ids] - robot.applied_torque[:, ids]), dim=1)


# -- actions ----------------------------------------------------------------------------------------

def action_rate_l2(env) -> torch.Tensor:
    manager = env.action_manager
    return torch.sum(torch.square(manager.action - manager.prev_action), dim=1)


def action_rate_rate_l2(env) -> torch.Tensor:
    """Squared second difference of the actions."""
    manager = env.action_manager
    return torch.sum(torch.square(manager.action - 2.0 * manager.prev_action + manager.prev_prev_action), dim=1)


# -- feet (poses only; contact-based foot terms need the contact sensor) ----------------------------

def _feet_quat(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """(N, B, 4) orientations (x, y, z, w) of the selected bodies."""
    return env.scene[asset_cfg.name].body_pose_w[:, asset_cfg.body_ids, 3:7]


def feet_roll_l2(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """Sum of the feet's squared roll, each about the foot's own x axis [rad²]."""
    x, y, z, w = _feet_quat(env, asset_cfg).unbind(-1)
    roll = torch.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return torch.sum(torch.square(roll), dim=1)


def feet_yaw_diff_l2(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """Squared yaw difference between the two feet."""
    yaw = yaw_from_quat(_feet_quat(env, asset_cfg))
    return torch.square(wrap_to_pi(yaw[:, 1] - yaw[:, 0]))


def feet_yaw_mean_vs_base(env, feet_asset_cfg: SceneEntityCfg, base_body_cfg: SceneEntityCfg) -> torch.Tensor:
    """Sum over the feet of the squared yaw of each foot in the frame of one base body (AGILE's name; toes
    turned in or out both cost, as does a base twisted against the feet) [rad²]."""
    if len(base_body_cfg.body_ids) != 1:
        raise ValueError(f"feet_yaw_mean_vs_base needs one base body, got {base_body_cfg.body_names}")
    yaw_in_base = env.scene[feet_asset_cfg.name].body_yaw_in_frame(feet_asset_cfg.body_ids, base_body_cfg.body_ids)
    return torch.sum(torch.square(yaw_in_base), dim=1)


def feet_distance_from_ref(env, ref_distance_m: float, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """|lateral distance between the feet in the base yaw frame - reference| [m]."""
    robot = env.scene[asset_cfg.name]
    feet_pos = robot.body_pose_w[:, asset_cfg.body_ids, :3]
    delta_w = feet_pos[:, 0] - feet_pos[:, 1]
    heading = robot.heading_w
    lateral = -torch.sin(heading) * delta_w[:, 0] + torch.cos(heading) * delta_w[:, 1]
    return torch.abs(lateral.abs() - ref_distance_m)


# -- contacts (the contact sensor: SceneEntityCfg("contact_forces", body_names=...)) ----------------
# Forces are world-frame [N]; "recent" means any of the sensor's history of physics steps.

def _recent_contact(env, sensor_cfg: SceneEntityCfg, force_threshold_n: float) -> torch.Tensor:
    """(N, B) bool: the selected bodies' net force exceeded the threshold at one of the recent physics steps."""
    history = env.scene[sensor_cfg.name].net_forces_w_history[:, :, sensor_cfg.body_ids]
    return torch.norm(history, dim=-1).amax(dim=1) > force_threshold_n


def _moving_command(env, command_name: str, min_command_speed_mps: float) -> torch.Tensor:
    return torch.norm(env.command_manager.get_command(command_name)[:, :2], dim=1) > min_command_speed_mps


def undesired_contacts(env, force_threshold_n: float, sensor_cfg: SceneEntityCfg) -> torch.Tensor:
    """Number of selected bodies in recent contact."""
    return torch.sum(_recent_contact(env, sensor_cfg, force_threshold_n), dim=1).float()


def illegal_contact(env, force_threshold_n: float, sensor_cfg: SceneEntityCfg) -> torch.Tensor:
    """1.0 where any selected body is in recent contact, else 0 (Isaac Lab's `illegal_contact` termination used as a
    reward, as AGILE StandUp-T1 does: a lying robot costs the weight once, not once per body on the ground)."""
    return _recent_contact(env, sensor_cfg, force_threshold_n).any(dim=1).float()


def feet_slip(env, sensor_cfg: SceneEntityCfg, asset_cfg: SceneEntityCfg,
              force_threshold_n: float = 1.0) -> torch.Tensor:
    """Sum over feet in recent contact of the foot's horizontal speed [m/s].

    sensor_cfg and asset_cfg must name the same feet in the same order (sensor bodies vs robot bodies).
    """
    in_contact = _recent_contact(env, sensor_cfg, force_threshold_n)
    feet_vel_xy = env.scene[asset_cfg.name].body_vel_w[:, asset_cfg.body_ids, :2]
    return torch.sum(torch.norm(feet_vel_xy, dim=-1) * in_contact, dim=1)


def jumping(env, force_threshold_n: float, sensor_cfg: SceneEntityCfg) -> torch.Tensor:
    """1 when no selected foot pushes on anything at the last physics step (AGILE G1: 10 N)."""
    forces = torch.norm(env.scene[sensor_cfg.name].net_forces_w[:, sensor_cfg.body_ids], dim=-1)
    return (forces < force_threshold_n).all(dim=1).float()


def feet_stumble(env, sensor_cfg: SceneEntityCfg, force_threshold_n: float = 1.0) -> torch.Tensor:
    """AGILE: the largest recent horizontal contact force on any selected foot above the threshold [N]."""
    history = env.scene[sensor_cfg.name].net_forces_w_history[:, :, sensor_cfg.body_ids, :2]
    largest = torch.norm(history, dim=-1).flatten(1).amax(dim=1)
    return torch.relu(largest - force_threshold_n)


def impact_velocity_l1(env, sensor_cfg: SceneEntityCfg, force_threshold_n: float = 10.0) -> torch.Tensor:
    """Sum over feet in recent contact of their largest recent speed [m/s]: the speed at touchdown, since
    the history reaches back to the physics steps before the impact."""
    sensor = env.scene[sensor_cfg.name]
    in_contact = _recent_contact(env, sensor_cfg, force_threshold_n)
    speed = torch.norm(sensor.lin_vel_w_history[:, :, sensor_cfg.body_ids], dim=-1).amax(dim=1)
    return torch.sum(speed * in_contact, dim=1)


def equal_foot_force(env, sensor_cfg: SceneEntityCfg) -> torch.Tensor:
    """1 - mean |F_z,foot - mean F_z| / mean F_z: 1 for an even vertical load, 0 with all of it on one of two feet."""
    feet_z = env.scene[sensor_cfg.name].net_forces_w[:, sensor_cfg.body_ids, 2].abs()
    mean = feet_z.mean(dim=1)
    # no load at all (flight) scores 1, like an even split: the epsilon only avoids 0/0
    return 1.0 - torch.abs(feet_z - mean.unsqueeze(1)).mean(dim=1) / (mean + 1e-6)


def feet_air_time(env, command_name: str, threshold_s: float, sensor_cfg: SceneEntityCfg,
                  min_command_speed_mps: float = 0.1) -> torch.Tensor:
    """Isaac Lab: at each touchdown, the flight time minus threshold_s [s], summed over feet; 0 when the
    commanded planar speed is at most min_command_speed_mps."""
    sensor = env.scene[sensor_cfg.name]
    first_contact = sensor.compute_first_contact(env.step_dt)[:, sensor_cfg.body_ids]
    last_air_time = sensor.last_air_time_s[:, sensor_cfg.body_ids]
    reward = torch.sum((last_air_time - threshold_s) * first_contact, dim=1)
    return reward * _moving_command(env, command_name, min_command_speed_mps)


def feet_air_time_positive_biped(env, command_name: str, threshold_s: float, sensor_cfg: SceneEntityCfg,
                                 min_command_speed_mps: float = 0.1) -> torch.Tensor:
    """Isaac Lab: in single stance, the shorter of the two feet's current phase times, capped at threshold_s [s];
    0 in double stance or flight, and when the commanded planar speed is at most min_command_speed_mps."""
    sensor = env.scene[sensor_cfg.name]
    air_time = sensor.current_air_time_s[:, sensor_cfg.body_ids]
    contact_time = sensor.current_contact_time_s[:, sensor_cfg.body_ids]
    in_contact = contact_time > 0.0
    phase_time = torch.where(in_contact, contact_time, air_time)
    single_stance = torch.sum(in_contact.int(), dim=1) == 1
    reward = torch.where(single_stance.unsqueeze(-1), phase_time, 0.0).amin(dim=1).clamp(max=threshold_s)
    return reward * _moving_command(env, command_name, min_command_speed_mps)


# -- objects --------------------------------------------------------------------------------------

OBJECT = SceneEntityCfg("object")


def object_is_lifted(env, minimal_height_m: float, object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """1 while the object's root is higher than `minimal_height_m` above its env origin (Isaac Lab's)."""
    return (env.scene[object_cfg.name].root_pos_env[:, 2] > minimal_height_m).float()


def object_body_distance_exp(env, std_m: float, body_cfg: SceneEntityCfg,
                             object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """exp(-d / std) with d the distance [m] from the object's root to the first selected body's origin (a
    palm or fingertip reaching for the object)."""
    robot = env.scene[body_cfg.name]
    body_pos_w = robot.body_pose_w[:, body_cfg.body_ids, :3].reshape(env.num_envs, -1, 3)[:, 0]
    distance = torch.linalg.norm(env.scene[object_cfg.name].root_pos_w - body_pos_w, dim=-1)
    return torch.exp(-distance / std_m)


def filtered_contact(env, sensor_cfg: SceneEntityCfg, force_threshold_n: float = 1.0) -> torch.Tensor:
    """1 where a selected body is pushed by the sensor's filter entity (e.g. the other robot) harder than the
    threshold [N], else 0. The sensor needs a `filter_entity`."""
    sensor = env.scene[sensor_cfg.name]
    if sensor.force_matrix_w is None:
        raise ValueError(f"filtered_contact: contact sensor '{sensor_cfg.name}' has no filter_entity")
    force_n = torch.norm(sensor.force_matrix_w[:, sensor_cfg.body_ids].sum(dim=2), dim=-1)
    return (force_n > force_threshold_n).any(dim=1).float()


def body_ang_vel_l2(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """|angular velocity|² of the selected bodies, summed [rad²/s²]."""
    robot = env.scene[asset_cfg.name]
    return torch.sum(torch.square(robot.body_vel_w[:, asset_cfg.body_ids, 3:6]), dim=(1, 2))


def action_l2(env) -> torch.Tensor:
    return torch.sum(torch.square(env.action_manager.action), dim=-1)


def is_terminated_term(env, term_keys: list[str] | str) -> torch.Tensor:
    """(N,) 1.0 where any of the termination terms `term_keys` ended the episode this step, else 0 (AGILE: a
    penalty for particular failures, e.g. `no_height_progress`, rather than for every termination)."""
    names = [term_keys] if isinstance(term_keys, str) else list(term_keys)
    term_dones = env.termination_manager.term_dones
    unknown = [name for name in names if name not in term_dones]
    if unknown or not names:
        raise ValueError(f"is_terminated_term: term_keys must name termination terms, got unknown {unknown} "
                         f"(of {names}); the termination terms are {list(term_dones)}")
    return torch.stack([term_dones[name] for name in names]).any(dim=0).float()
