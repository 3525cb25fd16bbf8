"""Terms of pick-and-place tracking (AGILE `PickPlace-G1-v0`): the palm frame, observations, rewards and
terminations that compare the robot and the object with the reference of a `TrackingCommand`.

The anchor terms of motion tracking (`motion_anchor_pos_b`, `motion_global_anchor_position_error_exp`, ...) read
the same attributes of a TrackingCommand and are used as they are. Rewards are exp(-error / std²) with the error
a squared distance [m², rad²].
"""

from __future__ import annotations

import functools

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.rl_env.mdp.motion_tracking import quat_error_magnitude
from agile.utils.math import quat_rotate, quat_rotate_inverse

__all__ = ["action_l2", "bad_base_pose", "bad_base_rotation", "bad_joint_pos", "body_ang_vel_l2",
           "hand_object_distance_tracking_exp", "motion_joint_pos_delta", "motion_object_position_error_exp",
           "motion_tracked_joint_pos_error_exp", "nominal_posture_at_end_exp", "object_pos_error",
           "object_to_hand_pos_b", "out_of_bound", "palm_object_distance_exp", "palm_pose_w", "static_at_goal_exp",
           "trajectory_progress"]

OBJECT = SceneEntityCfg("object")


def _reference(env, command_name: str):
    return env.command_manager.get_term(command_name)


# -- the palm frame: a fixed offset from a body (AGILE: an `ee_frame` FrameTransformer on the right palm) ---------

@functools.lru_cache(maxsize=16)
def _offset_tensor(offset_m: tuple[float, float, float], device) -> torch.Tensor:
    """The offset on the device, made once: a captured step may not copy from the host."""
    return torch.tensor(offset_m, dtype=torch.float32, device=device)


def palm_pose_w(env, palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float]) -> tuple[torch.Tensor,
                                                                                                 torch.Tensor]:
    """(N, 3) position [m] and (N, 4) orientation (x, y, z, w) of the point `offset_m` in the frame of the first
    body of `palm_cfg`, world frame."""
    robot = env.scene[palm_cfg.name]
    pose = robot.body_pose_w[:, palm_cfg.body_ids].reshape(env.num_envs, -1, 7)[:, 0]
    offset = _offset_tensor(tuple(offset_m), pose.device).expand(env.num_envs, 3)
    return pose[:, :3] + quat_rotate(pose[:, 3:7], offset), pose[:, 3:7]


# -- observations ---------------------------------------------------------------------------------------------

def motion_joint_pos_delta(env, command_name: str) -> torch.Tensor:
    """(N, J) the tracked joints' reference minus their positions [rad]."""
    reference = _reference(env, command_name)
    return reference.joint_pos - reference.robot_joint_pos


def object_to_hand_pos_b(env, palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float],
                         object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """(N, 3) the object's position in the palm frame [m]."""
    palm_pos, palm_quat = palm_pose_w(env, palm_cfg, offset_m)
    return quat_rotate_inverse(palm_quat, env.scene[object_cfg.name].root_pos_w - palm_pos)


def object_pos_error(env, command_name: str, object_cfg: SceneEntityCfg = OBJECT,
                     asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """(N, 3) the object's reference position minus its position, in the robot's root frame [m]."""
    robot = env.scene[asset_cfg.name]
    error_w = _reference(env, command_name).object_pos_w - env.scene[object_cfg.name].root_pos_w
    return quat_rotate_inverse(robot.root_quat_w, error_w)


def trajectory_progress(env, command_name: str) -> torch.Tensor:
    """(N, 1) the reference's progress, 0 at its start and 1 at its end."""
    return _reference(env, command_name).progress.unsqueeze(-1)


# -- rewards ----------------------------------------------------------------------------------------------------

def motion_tracked_joint_pos_error_exp(env, command_name: str, std: float) -> torch.Tensor:
    reference = _reference(env, command_name)
    error = torch.sum(torch.square(reference.joint_pos - reference.robot_joint_pos), dim=-1)
    return torch.exp(-error / std**2)


def motion_object_position_error_exp(env, command_name: str, std: float,
                                     object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    error_w = _reference(env, command_name).object_pos_w - env.scene[object_cfg.name].root_pos_w
    return torch.exp(-torch.sum(torch.square(error_w), dim=-1) / std**2)


def hand_object_distance_tracking_exp(env, command_name: str, std: float, release_decay_steps: int,
                                      palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float],
                                      object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """exp(-|palm - object|² / std²) while the reference holds the object (grasp and carry), fading linearly to 0
    over `release_decay_steps` env steps after it lets go; 0 before the grasp."""
    reference = _reference(env, command_name)
    fade = (1.0 - reference.steps_since_release / release_decay_steps).clamp(min=0.0)
    weight = torch.where(reference.in_hand, 1.0, torch.where(reference.released, fade, 0.0))
    return weight * palm_object_distance_exp(env, std, palm_cfg, offset_m, object_cfg)


def palm_object_distance_exp(env, std_m: float, palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float],
                             object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """exp(-|palm - object|² / std²): the palm reaching the object, whatever the reference (the debug task)."""
    palm_pos, _ = palm_pose_w(env, palm_cfg, offset_m)
    distance_sq = torch.sum(torch.square(env.scene[object_cfg.name].root_pos_w - palm_pos), dim=-1)
    return torch.exp(-distance_sq / std_m**2)


def static_at_goal_exp(env, command_name: str, progress_threshold: float, joint_vel_std: float,
                       root_vel_std: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-|tracked joint velocities|² / σj²) · exp(-|root velocity|² / σr²), ramped in from 0 at
    `progress_threshold` to 1 at the reference's end: be still once the task is done."""
    reference = _reference(env, command_name)
    robot = env.scene[asset_cfg.name]
    joint_vel_sq = torch.sum(torch.square(robot.joint_vel[:, reference.joint_ids]), dim=-1)
    root_vel_sq = torch.sum(torch.square(robot.root_lin_vel_w), dim=-1) + torch.sum(
        torch.square(robot.root_ang_vel_w), dim=-1)
    ramp = ((reference.progress - progress_threshold) / (1.0 - progress_threshold)).clamp(0.0, 1.0)
    return ramp * torch.exp(-joint_vel_sq / joint_vel_std**2) * torch.exp(-root_vel_sq / root_vel_std**2)


def nominal_posture_at_end_exp(env, command_name: str, progress_threshold: float, std: float) -> torch.Tensor:
    """exp(-|tracked joints - the reference's last frame|² / std²) once the progress passes the threshold."""
    reference = _reference(env, command_name)
    error = torch.sum(torch.square(reference.final_joint_pos - reference.robot_joint_pos), dim=-1)
    return (reference.progress > progress_threshold).float() * torch.exp(-error / std**2)


def body_ang_vel_l2(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """|angular velocity|² of the selected bodies, summed [rad²/s²]."""
    robot = env.scene[asset_cfg.name]
    return torch.sum(torch.square(robot.body_vel_w[:, asset_cfg.body_ids, 3:6]), dim=(1, 2))


def action_l2(env) -> torch.Tensor:
    return torch.sum(torch.square(env.action_manager.action), dim=-1)


# -- terminations -----------------------------------------------------------------------------------------------

def bad_base_pose(env, command_name: str, threshold_m: float) -> torch.Tensor:
    """The anchor body is farther than `threshold_m` from its reference position."""
    reference = _reference(env, command_name)
    return torch.linalg.norm(reference.anchor_pos_w - reference.robot_anchor_pos_w, dim=-1) > threshold_m


def bad_base_rotation(env, command_name: str, threshold_rad: float) -> torch.Tensor:
    """The anchor body is turned more than `threshold_rad` from its reference orientation."""
    reference = _reference(env, command_name)
    return quat_error_magnitude(reference.anchor_quat_w, reference.robot_anchor_quat_w) > threshold_rad


def bad_joint_pos(env, command_name: str, threshold_rad: float) -> torch.Tensor:
    """The tracked joints are farther than `threshold_rad` (Euclidean norm) from their reference."""
    reference = _reference(env, command_name)
    return torch.linalg.norm(reference.joint_pos - reference.robot_joint_pos, dim=-1) > threshold_rad


def out_of_bound(env, z_range_m: tuple[float, float], asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """The entity's root height above its env origin is outside `z_range_m`."""
    z = env.scene[asset_cfg.name].root_pos_env[:, 2]
    return (z < z_range_m[0]) | (z > z_range_m[1])
