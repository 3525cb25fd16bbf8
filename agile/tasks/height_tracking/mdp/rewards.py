"""Reward terms of the sit-down / stand-up task (AGILE V1.3 HeightTracking-G1): tracking a height command
(`SmoothHeightCommand`, its `measured_height_m` and `target_height_m`), lying relaxed on a negative command, and
the posture, contact and smoothness terms that make the motion slow and safe. All masked tensor math, no host
sync; the body tilt is measured from each body's z axis against world up."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, ManagerTermBase, SceneEntityCfg
from agile.rl_env.mdp.rewards import body_projected_gravity
from agile.tasks.stand_up.mdp.rewards import joint_deviation_if_standing, standing
from agile.utils.math import quat_conjugate, quat_mul, yaw_from_quat

__all__ = ["body_orientation_penalty", "bodies_lin_vel_l2", "completely_airborne", "feet_distance_3d",
           "feet_distance_3d_if_standing", "foot_orientation_l1", "ground_unloaded", "impact_velocity",
           "joint_deviation_if_standing_asked", "joint_pos_tracking_error_l2", "moving_if_tracking",
           "relaxation_penalty", "severely_tilted_penalty", "track_height_command_exp",
           "upright_orientation_after_standing"]

ORIENTATION_AXES = ("roll", "pitch")
ORIENTATION_DIRECTIONS = ("both", "forward", "backward")
KERNELS = ("l1", "l2")


def _check(name: str, value: str, valid: tuple[str, ...], term: str) -> None:
    if value not in valid:
        raise ValueError(f"{term}: {name} must be one of {valid}, got {value!r}")


def _kernel(values: torch.Tensor, kernel: str, term: str) -> torch.Tensor:
    _check("kernel", kernel, KERNELS, term)
    return values.abs() if kernel == "l1" else torch.square(values)


def _height_error_m(env, command_name: str) -> torch.Tensor:
    command = env.command_manager.get_term(command_name)
    return command.measured_height_m - command.target_height_m


def _bodies_tilt_rad(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """(N, B) angle between each selected body's z axis and world up [rad]: 0 upright, π upside down."""
    return torch.acos((-body_projected_gravity(env, asset_cfg)[..., 2]).clamp(-1.0, 1.0))


# -- the height command ------------------------------------------------------------------------------------------

def track_height_command_exp(env, command_name: str, std: float) -> torch.Tensor:
    """exp(-(h - h_cmd)² / std²), h the command's tracked point above the terrain [m]. AGILE uses three widths
    (0.5, 0.3, 0.2 m) so that the gradient reaches from afar and sharpens close to the target."""
    return torch.exp(-torch.square(_height_error_m(env, command_name)) / std**2)


def relaxation_penalty(env, command_name: str, asset_cfg: SceneEntityCfg = ROBOT, pos_weight: float = 1.0,
                       torque_weight: float = 1.0e-3) -> torch.Tensor:
    """While the command is negative (lie relaxed): intensity · pos_weight · Σ(q - q_default)² [rad²] +
    torque_weight · Σ τ² [N²·m²], intensity the command's `relaxation_intensity` (0 at a command of 0, 1 at the
    bottom of its range): lie in the default joint pose and let the motors go slack; 0 while the command is
    >= 0."""
    command = env.command_manager.get_term(command_name)
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    deviation = robot.joint_pos[:, ids] - robot.default_joint_pos[:, ids]
    torque_sq = torch.sum(torch.square(robot.applied_torque[:, ids]), dim=1)
    relaxing = (command.target_height_m < 0.0).float()
    return (command.relaxation_intensity * pos_weight * torch.sum(torch.square(deviation), dim=1)
            + relaxing * torque_weight * torque_sq)


def joint_pos_tracking_error_l2(env, action_name: str = "joint_pos", asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Σ (q_target - q)² over the joints of the action term `action_name` [rad²]: targets the joints can follow,
    not far-away targets that turn the PD into a torque command."""
    action = env.action_manager.get_term(action_name)
    joint_pos = env.scene[asset_cfg.name].joint_pos[:, action.joint_ids]
    return torch.sum(torch.square(action.processed_actions - joint_pos), dim=1)


def moving_if_tracking(env, command_name: str, error_threshold_m: float, asset_cfg: SceneEntityCfg = ROBOT,
                       weight_lin: float = 1.0, weight_ang: float = 1.0) -> torch.Tensor:
    """Once the tracked point is within `error_threshold_m` of the command: weight_lin · mean |v| [m/s] +
    weight_ang · mean |ω| [rad/s] over the selected bodies (all by default; AGILE's `moving`): stay still at the
    target; 0 while still on the way."""
    velocity = env.scene[asset_cfg.name].body_vel_w[:, asset_cfg.body_ids]
    moving = (weight_lin * torch.norm(velocity[..., :3], dim=-1).mean(dim=1)
              + weight_ang * torch.norm(velocity[..., 3:], dim=-1).mean(dim=1))
    return moving * (_height_error_m(env, command_name).abs() < error_threshold_m)


def joint_deviation_if_standing_asked(env, min_height_m: float, asset_cfg: SceneEntityCfg, command_name: str,
                                     min_command_m: float | None = None, norm: str = "l1",
                                     sensor_name: str | None = None) -> torch.Tensor:
    """`joint_deviation_if_standing` (the root above `min_height_m`: AGILE's gate), and only while the height
    command asks for at least `min_command_m` [m] (None: whatever it asks, AGILE's term).

    Why a command gate: the root-height gate comes from StandUp, whose only goal is standing. Here, every posture
    that holds the tracked point between about 0.65 and 0.85 m has the root above 0.5 m with the knees bent, and
    pays the whole deviation from the default pose (legs and arms, l1, weight -0.5: 3-7.5 per step), as much as the
    height rewards gain by reaching the command; the trained policy stays below the gate instead (docs/height_tracking.md,
    "the reward balance")."""
    deviation = joint_deviation_if_standing(env, min_height_m, asset_cfg, norm, sensor_name)
    if min_command_m is None:
        return deviation
    return deviation * (env.command_manager.get_term(command_name).target_height_m >= min_command_m)


class ground_unloaded(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """1 - clamp(Σ F_z over the selected contact bodies / robot weight, 0, 1) [0-1]: how much of the robot's weight
    the feet do not carry (1 airborne or on the knees, 0 standing on its feet); while the height command is >= 0
    only (`command_name`; None: always). The weight is the robot's masses as built (`asset_cfg`) times g."""

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        robot = env.scene[cfg.params.get("asset_cfg", ROBOT).name]
        self.weight_n = robot.body_mass.sum(dim=1).clone() * abs(env.cfg.sim.gravity_mps2)

    def __call__(self, env, sensor_cfg: SceneEntityCfg, asset_cfg: SceneEntityCfg = ROBOT,
                 command_name: str | None = None) -> torch.Tensor:
        support_n = env.scene[sensor_cfg.name].net_forces_w[:, sensor_cfg.body_ids, 2].sum(dim=1)
        unloaded = 1.0 - (support_n / self.weight_n).clamp(0.0, 1.0)
        if command_name is not None:
            unloaded = unloaded * (env.command_manager.get_term(command_name).target_height_m >= 0.0)
        return unloaded


# -- orientation -------------------------------------------------------------------------------------------------

class upright_orientation_after_standing(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """Σ over the selected bodies of their tilt [rad] (norm "l1") or tilt² [rad²] ("l2"), once the root has been
    more than `min_height_m` above the terrain (under `sensor_name`) for `min_standing_duration_s` without a break;
    0 before: an upright torso once up, any posture on the way up."""

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        self.standing_duration_s = torch.zeros(env.num_envs, device=env.device)

    def __call__(self, env, min_height_m: float, min_standing_duration_s: float, asset_cfg: SceneEntityCfg,
                 sensor_name: str | None = None, norm: str = "l1") -> torch.Tensor:
        up = standing(env, min_height_m, sensor_name, asset_cfg)
        self.standing_duration_s.copy_(torch.where(up, self.standing_duration_s + env.step_dt, 0.0))
        tilt = torch.sum(_kernel(_bodies_tilt_rad(env, asset_cfg), norm, "upright_orientation_after_standing"), dim=1)
        return tilt * (self.standing_duration_s >= min_standing_duration_s)

    def reset(self, env_mask: torch.Tensor) -> None:
        self.standing_duration_s.masked_fill_(env_mask, 0.0)


def severely_tilted_penalty(env, asset_cfg: SceneEntityCfg, threshold_rad: float) -> torch.Tensor:
    """1 when any selected body is tilted more than `threshold_rad` from upright (AGILE: pelvis or torso past
    135°, i.e. upside down), else 0; from the episode's first step."""
    return (_bodies_tilt_rad(env, asset_cfg) > threshold_rad).any(dim=1).float()


def body_orientation_penalty(env, asset_cfg: SceneEntityCfg, axis: str = "roll", direction: str = "both",
                             kernel: str = "l1") -> torch.Tensor:
    """Mean over the selected bodies of the gravity direction's component in the body frame along y ("roll":
    positive leaning right) or x ("pitch": positive leaning forward), kept positive ("forward"), negative
    ("backward", sign flipped) or both (|·|), then |·| ("l1") or squared ("l2") [unit vector component]."""
    term = "body_orientation_penalty"
    _check("axis", axis, ORIENTATION_AXES, term)
    _check("direction", direction, ORIENTATION_DIRECTIONS, term)
    gravity_b = body_projected_gravity(env, asset_cfg)
    component = gravity_b[..., 0] if axis == "pitch" else gravity_b[..., 1]
    if direction == "forward":
        component = component.clamp(min=0.0)
    elif direction == "backward":
        component = (-component).clamp(min=0.0)
    return _kernel(component, kernel, term).mean(dim=1)


# -- feet --------------------------------------------------------------------------------------------------------

def feet_distance_3d(env, ref_distance_m: float, asset_cfg: SceneEntityCfg, error_threshold_m: float = 0.0,
                     close_multiplier: float = 1.0, norm: str = "l1", episode_delay_s: float = 0.0,
                     episode_ramp_s: float = 0.0) -> torch.Tensor:
    """AGILE `feet_distance_from_ref` with distance_mode "absolute": e = |p_foot0 - p_foot1| (3-D, world, so it
    means the same lying or standing) - ref_distance_m; feet too close count at once (e·close_multiplier), too
    far only past `error_threshold_m` (then the whole e); |e| ("l1") or e² ("l2") [m, m²]; scaled from 0 during
    the first `episode_delay_s` to 1 over the next `episode_ramp_s` of the episode (time to recover from a fall)."""
    if len(asset_cfg.body_ids) != 2:
        raise ValueError(f"feet_distance_3d needs two feet, got {asset_cfg.body_names}")
    feet_pos = env.scene[asset_cfg.name].body_pose_w[:, asset_cfg.body_ids, :3]
    error_m = torch.norm(feet_pos[:, 0] - feet_pos[:, 1], dim=1) - ref_distance_m
    error_m = torch.where(error_m < 0.0, error_m * close_multiplier,
                          torch.where(error_m > error_threshold_m, error_m, 0.0))
    elapsed_s = env.episode_length_buf * env.step_dt
    if episode_ramp_s > 0.0:
        ramp = ((elapsed_s - episode_delay_s) / episode_ramp_s).clamp(0.0, 1.0)
    else:
        ramp = (elapsed_s >= episode_delay_s).float()
    return _kernel(error_m, norm, "feet_distance_3d") * ramp


def feet_distance_3d_if_standing(env, min_height_m: float, ref_distance_m: float, asset_cfg: SceneEntityCfg,
                                 sensor_name: str | None = None, **feet_distance_params) -> torch.Tensor:
    """`feet_distance_3d` while the root is more than `min_height_m` above the terrain, else 0."""
    distance = feet_distance_3d(env, ref_distance_m, asset_cfg, **feet_distance_params)
    return distance * standing(env, min_height_m, sensor_name, asset_cfg)


def _roll_pitch(quat_xyzw: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    x, y, z, w = quat_xyzw.unbind(-1)
    roll = torch.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = torch.asin((2.0 * (w * y - z * x)).clamp(-1.0, 1.0))
    return roll, pitch


def foot_orientation_l1(env, asset_cfg: SceneEntityCfg, roll_weight: float = 1.0, pitch_weight: float = 1.0,
                        yaw_weight: float = 1.0) -> torch.Tensor:
    """Weighted mean over the feet of |roll|, |pitch| and |yaw| [rad] of each foot in the root's yaw frame (roll
    and pitch: flat on the ground; yaw: pointing where the base faces)."""
    robot = env.scene[asset_cfg.name]
    feet_quat = robot.body_pose_w[:, asset_cfg.body_ids, 3:7]
    heading = robot.heading_w
    zeros = torch.zeros_like(heading)
    half = 0.5 * heading
    heading_quat = torch.stack((zeros, zeros, torch.sin(half), torch.cos(half)), dim=-1)
    feet_in_yaw_frame = quat_mul(quat_conjugate(heading_quat).unsqueeze(1).expand_as(feet_quat), feet_quat)
    roll, pitch = _roll_pitch(feet_in_yaw_frame)
    yaw = yaw_from_quat(feet_in_yaw_frame)
    return (roll_weight * roll.abs().mean(dim=1) + pitch_weight * pitch.abs().mean(dim=1)
            + yaw_weight * yaw.abs().mean(dim=1))


# -- contacts and speed ------------------------------------------------------------------------------------------

def completely_airborne(env, sensor_cfg: SceneEntityCfg, force_threshold_n: float = 1.0) -> torch.Tensor:
    """1 when none of the selected bodies (AGILE: all) pushes on anything harder than the threshold at the last
    physics step: jumping or thrown; lying, kneeling or standing all touch."""
    forces = torch.norm(env.scene[sensor_cfg.name].net_forces_w[:, sensor_cfg.body_ids], dim=-1)
    return (forces <= force_threshold_n).all(dim=1).float()


def bodies_lin_vel_l2(env, asset_cfg: SceneEntityCfg, threshold_mps: float = 0.0) -> torch.Tensor:
    """Σ over the selected bodies of max(|v| - threshold_mps, 0)² [m²/s²]: every part moves slowly, with a
    dead zone."""
    speed = torch.norm(env.scene[asset_cfg.name].body_vel_w[:, asset_cfg.body_ids, :3], dim=-1)
    return torch.sum(torch.square((speed - threshold_mps).clamp(min=0.0)), dim=1)


def impact_velocity(env, sensor_cfg: SceneEntityCfg, force_threshold_n: float = 10.0,
                    kernel: str = "l1") -> torch.Tensor:
    """AGILE V1.3 `impact_velocity`: Σ over the selected bodies in contact at any recent physics step (force above
    the threshold) of their current speed [m/s] ("l1") or its square ("l2"): no slamming into the ground."""
    sensor = env.scene[sensor_cfg.name]
    ids = sensor_cfg.body_ids
    in_contact = torch.norm(sensor.net_forces_w_history[:, :, ids], dim=-1).amax(dim=1) > force_threshold_n
    speed = torch.norm(sensor.lin_vel_w_history[:, 0, ids], dim=-1)
    return torch.sum(_kernel(speed, kernel, "impact_velocity") * in_contact, dim=1)
