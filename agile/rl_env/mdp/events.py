"""Event terms: functions (env, env_mask, **params) that write the simulation where env_mask (N,) is True."""

from __future__ import annotations

import functools

import newton
import torch
import warp as wp

from agile.actuators import ExplicitActuatorGroup
from agile.rl_env.managers import ROBOT, SceneEntityCfg, index_list

__all__ = ["apply_external_force_torque", "push_by_setting_velocity", "randomize_actuator_gains",
           "randomize_joint_parameters", "randomize_rigid_body_com", "randomize_rigid_body_mass",
           "randomize_rigid_body_material", "reset_joints_by_scale", "reset_root_state_uniform"]

AXES = ("x", "y", "z", "roll", "pitch", "yaw")


@functools.lru_cache(maxsize=256)
def _bounds(items: tuple, device) -> tuple[torch.Tensor, torch.Tensor]:
    ranges = dict(items)
    unknown = set(ranges) - set(AXES)
    if unknown:
        raise ValueError(f"unknown range keys {sorted(unknown)}; expected a subset of {AXES}")
    low = torch.tensor([float(ranges.get(a, (0.0, 0.0))[0]) for a in AXES], device=device)
    high = torch.tensor([float(ranges.get(a, (0.0, 0.0))[1]) for a in AXES], device=device)
    return low, high


def _sample_ranges(ranges: dict[str, tuple[float, float]], n: int, device) -> torch.Tensor:
    """(n, 6) uniform samples for x, y, z, roll, pitch, yaw; missing axes are 0. The bounds are made once
    per distinct range dict, so a step makes no host-to-device copy."""
    low, high = _bounds(tuple(sorted((k, tuple(v)) for k, v in ranges.items())), device)
    return torch.rand(n, 6, device=device) * (high - low) + low


def reset_root_state_uniform(env, env_mask: torch.Tensor, pose_range: dict, velocity_range: dict,
                             asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Root at default pose + env origin + uniform offsets; root velocity uniform (world frame)."""
    robot = env.scene[asset_cfg.name]
    pose_delta = _sample_ranges(pose_range, env.num_envs, env.device)
    velocity = _sample_ranges(velocity_range, env.num_envs, env.device)
    robot.reset_root(pose_delta, velocity, env_mask)


def reset_joints_by_scale(env, env_mask: torch.Tensor, position_range: tuple[float, float],
                          velocity_range: tuple[float, float], asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Joint positions = default × U(position_range) and velocities = default × U(velocity_range),
    clamped to the position limits."""
    robot = env.scene[asset_cfg.name]
    pos = robot.default_joint_pos * (torch.rand_like(robot.joint_pos) * (position_range[1] - position_range[0])
                                     + position_range[0])
    vel = robot.default_joint_vel * (torch.rand_like(robot.joint_vel) * (velocity_range[1] - velocity_range[0])
                                     + velocity_range[0])
    pos = torch.clamp(pos, robot.joint_pos_limits[..., 0], robot.joint_pos_limits[..., 1])
    if asset_cfg.joint_ids != slice(None):
        keep = torch.ones(robot.num_joints, dtype=torch.bool, device=env.device)
        keep.index_fill_(0, asset_cfg.joint_ids, False)  # a scalar put by index would copy it from the host
        pos = torch.where(keep, robot.joint_pos, pos)
        vel = torch.where(keep, robot.joint_vel, vel)
    robot.write_joint_state(pos, vel, env_mask)


def push_by_setting_velocity(env, env_mask: torch.Tensor, velocity_range: dict,
                             asset_cfg: SceneEntityCfg = ROBOT, velocity_scale: torch.Tensor | None = None) -> None:
    """Add a uniform random velocity (x, y, z, roll, pitch, yaw; world frame) to the root. `velocity_scale`, a
    (6,) device tensor that a curriculum (`pushing_curriculum`) changes in place, scales each axis's draw."""
    robot = env.scene[asset_cfg.name]
    push = _sample_ranges(velocity_range, env.num_envs, env.device)
    if velocity_scale is not None:
        push = push * velocity_scale
    velocity = robot.root_com_vel_w + push
    robot.write_root_state(robot.root_pose_w, velocity, env_mask)


# -- domain randomisation of model parameters ---------------------------------------------------------
#
# Newton's model holds every world's robot; the terms below write per-world values into the model arrays and
# then tell SolverMuJoCo which groups changed, so that it republishes them into mujoco_warp's per-world model
# fields (body_mass, geom_friction, actuator_gainprm, dof_armature, ...). They are startup terms, as in AGILE:
# they act on the current values, so the mass scale on all bodies and the mass added to the base compose,
# and calling them again accumulates.

MIN_BODY_MASS_KG = 1e-3
"""A randomised body never gets lighter than this: MuJoCo needs positive mass on bodies with inertia."""
OPERATIONS = ("scale", "add", "abs")


def _forbid_capture(term: str) -> None:
    # republishing model parameters recomputes MuJoCo constants, with host reads: not inside a captured step
    if torch.cuda.is_available() and torch.cuda.is_current_stream_capturing():
        raise RuntimeError(f"event '{term}' changes model parameters and cannot run inside the captured env step; "
                           f"use mode='startup' (or capture_step=False)")


def _uniform(low_high: tuple[float, float], shape, device) -> torch.Tensor:
    low, high = float(low_high[0]), float(low_high[1])
    return torch.rand(shape, device=device) * (high - low) + low


def _apply_operation(values: torch.Tensor, sample: torch.Tensor, operation: str) -> torch.Tensor:
    if operation == "scale":
        return values * sample
    if operation == "add":
        return values + sample
    if operation == "abs":
        return sample
    raise ValueError(f"unknown operation '{operation}'; expected one of {OPERATIONS}")


def randomize_rigid_body_material(env, env_mask: torch.Tensor, static_friction_range: tuple[float, float],
                                  dynamic_friction_range: tuple[float, float],
                                  restitution_range: tuple[float, float], num_buckets: int = 64,
                                  make_consistent: bool = True, asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Per-shape friction of the selected bodies' collision shapes, drawn from `num_buckets` materials (Isaac Lab).

    A bucket is (static, dynamic, restitution), uniform in the ranges; with make_consistent, dynamic <= static.
    Each shape of each world gets a random bucket. MuJoCo has one sliding friction coefficient per geom: it
    gets the bucket's dynamic friction (the one that limits a slipping foot). A MuJoCo contact uses the larger
    coefficient of its two geoms, so the robot's value decides only on ground whose friction is at most the
    lower end of the range (set `scene.ground_friction` accordingly). Restitution is written to
    `model.shape_material_restitution` for Newton's other solvers; MuJoCo contacts do not model it.
    """
    _forbid_capture("randomize_rigid_body_material")
    if num_buckets < 1:
        raise ValueError(f"num_buckets must be >= 1, got {num_buckets}")
    entity = env.scene[asset_cfg.name]
    model = env.sim.model
    device = env.device
    selected = torch.isin(entity.shape_body, torch.tensor(index_list(asset_cfg.body_ids, entity.num_bodies),
                                                          device=device))
    shape_ids = entity.shape_ids[:, selected]

    buckets = torch.stack([_uniform(r, num_buckets, device)
                           for r in (static_friction_range, dynamic_friction_range, restitution_range)], dim=-1)
    if make_consistent:
        buckets[:, 1] = torch.minimum(buckets[:, 1], buckets[:, 0])
    material = buckets[torch.randint(0, num_buckets, shape_ids.shape, device=device)]  # (N, shapes, 3)
    m = env_mask.view(-1, 1)
    mu = wp.to_torch(model.shape_material_mu)
    restitution = wp.to_torch(model.shape_material_restitution)
    mu[shape_ids] = torch.where(m, material[..., 1], mu[shape_ids])
    restitution[shape_ids] = torch.where(m, material[..., 2], restitution[shape_ids])
    env.sim.solver.notify_model_changed(newton.ModelFlags.SHAPE_PROPERTIES)


def randomize_rigid_body_mass(env, env_mask: torch.Tensor, mass_distribution_params: tuple[float, float],
                              operation: str = "scale", recompute_inertia: bool = True,
                              asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Body masses: scale by, add [kg] or set to [kg] a uniform sample per env and body, applied to the masses
    as built, so a second event on a body replaces the first one's draw (Isaac Lab: AGILE's added trunk mass
    supersedes its ×0.95-1.05 on the trunk). With recompute_inertia the inertia scales with the mass."""
    _forbid_capture("randomize_rigid_body_mass")
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.body_ids
    mass = robot.body_mass.clone()
    selected = robot.default_body_mass[:, ids]
    sample = _uniform(mass_distribution_params, selected.shape, env.device)
    mass[:, ids] = _apply_operation(selected, sample, operation).clamp(min=MIN_BODY_MASS_KG)
    robot.set_body_mass(mass, env_mask, scale_inertia=recompute_inertia)
    env.sim.solver.notify_model_changed(newton.ModelFlags.BODY_INERTIAL_PROPERTIES)


def randomize_rigid_body_com(env, env_mask: torch.Tensor, com_range: dict[str, tuple[float, float]],
                             asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Shift the centre of mass of the selected bodies by uniform offsets [m] in the body frame (keys x, y, z)."""
    _forbid_capture("randomize_rigid_body_com")
    unknown = set(com_range) - {"x", "y", "z"}
    if unknown:
        raise ValueError(f"unknown com_range keys {sorted(unknown)}; expected a subset of ['x', 'y', 'z']")
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.body_ids
    com = robot.body_com_b[:, ids]
    offset = torch.stack([_uniform(com_range.get(axis, (0.0, 0.0)), com.shape[:2], env.device)
                          for axis in ("x", "y", "z")], dim=-1)
    robot.body_com_b[:, ids] = torch.where(env_mask.view(-1, 1, 1), com + offset, com)
    env.sim.solver.notify_model_changed(newton.ModelFlags.BODY_INERTIAL_PROPERTIES)


def randomize_actuator_gains(env, env_mask: torch.Tensor,
                             stiffness_distribution_params: tuple[float, float] | None = None,
                             damping_distribution_params: tuple[float, float] | None = None,
                             operation: str = "scale", asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """PD gains per env and joint. The model's joint_target_ke/kd (the solver's implicit PD, published to
    MuJoCo's actuator_gainprm/biasprm) are the source; explicit actuator groups copy their joints' new gains,
    because their torque model reads its own per-env gain tensors."""
    _forbid_capture("randomize_actuator_gains")
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    m = env_mask.view(-1, 1)
    for gains, params in ((robot.joint_stiffness, stiffness_distribution_params),
                          (robot.joint_damping, damping_distribution_params)):
        if params is None:
            continue
        selected = gains[:, ids]
        new = _apply_operation(selected, _uniform(params, selected.shape, env.device), operation).clamp(min=0.0)
        gains[:, ids] = torch.where(m, new, selected)
    for group in robot.actuator_groups:
        if isinstance(group, ExplicitActuatorGroup):
            group.stiffness.copy_(robot.joint_stiffness[:, group.joint_ids])
            group.damping.copy_(robot.joint_damping[:, group.joint_ids])
    env.sim.solver.notify_model_changed(newton.ModelFlags.JOINT_DOF_FORCE_PROPERTIES)


def randomize_joint_parameters(env, env_mask: torch.Tensor,
                               friction_distribution_params: tuple[float, float] | None = None,
                               armature_distribution_params: tuple[float, float] | None = None,
                               operation: str = "scale", asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Joint dry friction [N·m] (MuJoCo dof_frictionloss) and armature [kg·m²] (dof_armature) per env and joint."""
    _forbid_capture("randomize_joint_parameters")
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    m = env_mask.view(-1, 1)
    flags = 0
    for values, params, flag in ((robot.joint_friction, friction_distribution_params,
                                  newton.ModelFlags.JOINT_DOF_FORCE_PROPERTIES),
                                 (robot.joint_armature, armature_distribution_params,
                                  newton.ModelFlags.JOINT_DOF_INERTIAL_PROPERTIES)):
        if params is None:
            continue
        selected = values[:, ids]
        new = _apply_operation(selected, _uniform(params, selected.shape, env.device), operation).clamp(min=0.0)
        values[:, ids] = torch.where(m, new, selected)
        flags |= int(flag)
    if flags:
        env.sim.solver.notify_model_changed(flags)


# -- disturbances ----------------------------------------------------------------------------------

def apply_external_force_torque(env, env_mask: torch.Tensor, force_range: tuple[float, float],
                                torque_range: tuple[float, float], asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Draw a wrench per selected body, uniform per axis (force [N], torque [N·m]), that the solver applies at
    every physics step until the next draw or the env's reset (Isaac Lab's persistent external wrench).

    Unlike Isaac Lab (body frame), the wrench is held in the world frame: it then needs no work per physics
    step. Capturable: no host sync, fixed shapes.
    """
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.body_ids
    current = robot.body_wrench_w[:, ids]
    shape = (*current.shape[:2], 3)
    wrench = torch.cat((_uniform(force_range, shape, env.device), _uniform(torque_range, shape, env.device)), dim=-1)
    robot.body_wrench_w[:, ids] = torch.where(env_mask.view(-1, 1, 1), wrench, current)
