"""Zero-copy torch access to one replicated entity's root and bodies, and the one write path into them.

`Entity` is what articulations and rigid objects share: a root (free or fixed to the env) and bodies.
`RigidObject` is an entity of one body; `Articulation` (articulation.py) adds joints and actuators.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import newton
import numpy as np
import torch
import warp as wp

from agile.sim.names import resolve_names
from agile.utils.warp_math import quat_from_euler_xyz, quat_mul, rotate_inverse, yaw_of

GRAVITY_DIR_W = (0.0, 0.0, -1.0)


@wp.kernel(enable_backward=False)
def _root_frames(root_pose_w: wp.array2d(dtype=float), root_com_vel_w: wp.array2d(dtype=float),
                 gravity_dir_w: wp.vec3, root_lin_vel_b: wp.array2d(dtype=float),
                 root_ang_vel_b: wp.array2d(dtype=float), projected_gravity_b: wp.array2d(dtype=float),
                 heading_w: wp.array(dtype=float)):
    env = wp.tid()
    x, y, z, w = root_pose_w[env, 3], root_pose_w[env, 4], root_pose_w[env, 5], root_pose_w[env, 6]
    q_vec = wp.vec3(x, y, z)
    lin = rotate_inverse(q_vec, w, wp.vec3(root_com_vel_w[env, 0], root_com_vel_w[env, 1], root_com_vel_w[env, 2]))
    ang = rotate_inverse(q_vec, w, wp.vec3(root_com_vel_w[env, 3], root_com_vel_w[env, 4], root_com_vel_w[env, 5]))
    gravity = rotate_inverse(q_vec, w, gravity_dir_w)
    for k in range(3):
        root_lin_vel_b[env, k] = lin[k]
        root_ang_vel_b[env, k] = ang[k]
        projected_gravity_b[env, k] = gravity[k]
    heading_w[env] = yaw_of(x, y, z, w)


@wp.kernel(enable_backward=False)
def _reset_root(mask: wp.array(dtype=wp.bool), default_root_pose: wp.array2d(dtype=float),
                env_origins: wp.array2d(dtype=float), pose_delta: wp.array2d(dtype=float),
                com_vel_w: wp.array2d(dtype=float), write_velocity: int, root_pose_w: wp.array2d(dtype=float),
                root_com_vel_w: wp.array2d(dtype=float)):
    env = wp.tid()
    if not mask[env]:
        return
    for k in range(3):
        root_pose_w[env, k] = default_root_pose[env, k] + (env_origins[env, k] + pose_delta[env, k])
    turn = quat_from_euler_xyz(pose_delta[env, 3], pose_delta[env, 4], pose_delta[env, 5])
    default_quat = wp.vec4(default_root_pose[env, 3], default_root_pose[env, 4], default_root_pose[env, 5],
                           default_root_pose[env, 6])
    quat = quat_mul(turn, default_quat)
    for k in range(4):
        root_pose_w[env, 3 + k] = quat[k]
    if write_velocity != 0:
        for k in range(6):
            root_com_vel_w[env, k] = com_vel_w[env, k]


@wp.kernel(enable_backward=False)
def _yaw_in_frame(body_pose_w: wp.array3d(dtype=float), body_ids: wp.array(dtype=wp.int64),
                  frame_body_ids: wp.array(dtype=wp.int64), yaw: wp.array2d(dtype=float)):
    env, k = wp.tid()
    body, frame = int(body_ids[k]), int(frame_body_ids[0])
    frame_inverse = wp.vec4(-body_pose_w[env, frame, 3], -body_pose_w[env, frame, 4], -body_pose_w[env, frame, 5],
                            body_pose_w[env, frame, 6])
    q = quat_mul(frame_inverse, wp.vec4(body_pose_w[env, body, 3], body_pose_w[env, body, 4],
                                        body_pose_w[env, body, 5], body_pose_w[env, body, 6]))
    yaw[env, k] = yaw_of(q[0], q[1], q[2], q[3])


def body_yaw_in_frame(body_pose_w: torch.Tensor, body_ids: torch.Tensor | slice,
                      frame_body_ids: torch.Tensor) -> torch.Tensor:
    """(N, B) yaw [rad] of the bodies `body_ids` (an index tensor or a full slice, as `SceneEntityCfg.body_ids`) in
    the frame of the body `frame_body_ids` (1,), from poses (N, bodies, 7): the yaw of conj(q_frame) * q_body
    (`math.quat_mul` and `math.yaw_from_quat`), in one kernel."""
    if isinstance(body_ids, slice):
        body_ids = torch.arange(body_pose_w.shape[1], device=body_pose_w.device)[body_ids]
    yaw = torch.empty(body_pose_w.shape[0], len(body_ids), device=body_pose_w.device)
    wp.launch(_yaw_in_frame, dim=tuple(yaw.shape), device=wp.get_device(str(body_pose_w.device)),
              inputs=[wp.from_torch(body_pose_w), wp.from_torch(body_ids), wp.from_torch(frame_body_ids),
                      wp.from_torch(yaw)])
    return yaw


@dataclass(frozen=True)
class EntityLayout:
    """Where one entity's rows sit inside each world's block of Newton's arrays (every world holds the same
    entities in the same order, so one layout serves all worlds)."""

    coords: slice
    """Its joint coordinates in a world's `joint_q` (7 root coordinates first when floating)."""
    dofs: slice
    """Its DoFs in a world's `joint_qd` (6 root DoFs first when floating)."""
    bodies: slice
    joints: slice
    """Its joints in a world's joint arrays; the first is the root joint."""
    floating: bool
    """A free root joint (else the root is fixed to the env; its pose is the root joint's frame)."""


def world_block(array: wp.array, num_envs: int, *shape: int) -> torch.Tensor:
    """Zero-copy (num_envs, per-world, *shape) view of a world-major Newton array."""
    return wp.to_torch(array).view(num_envs, -1, *shape)


class Entity:
    """A root and bodies replicated once per world.

    Every tensor named `*_w`/`*_b` (world/body frame) is either a view of a Newton array (`root_pose_w`,
    `body_pose_w`, ...), so reading it costs nothing and writing it writes the simulation, or a derived
    quantity refreshed by `update()` once per env step. Quaternions are (x, y, z, w). Root linear velocities
    are those of the root body's centre of mass (Isaac Lab's `root_lin_vel_w`).
    """

    def __init__(self, name: str, model: newton.Model, state: newton.State, layout: EntityLayout,
                 body_names: list[str], step_dt_s: float, env_origins: torch.Tensor):
        n = model.world_count
        self.name = name
        self.num_envs = n
        self.layout = layout
        self.body_names = list(body_names)
        self.num_bodies = len(body_names)
        self.device = torch.device(wp.device_to_torch(model.device))
        self.is_fixed_base = not layout.floating
        self._step_dt_s = step_dt_s
        self.env_origins = env_origins
        """(N, 3) the env origins (the simulation's tensor, moved in place by terrain-level changes)."""
        if layout.bodies.stop - layout.bodies.start != self.num_bodies:
            raise ValueError(f"entity '{name}': {self.num_bodies} body names for {layout.bodies} bodies")

        self._coords = wp.to_torch(state.joint_q).view(n, -1)[:, layout.coords]
        self._dofs = wp.to_torch(state.joint_qd).view(n, -1)[:, layout.dofs]
        # -- root: a free root's pose and velocity are its joint coordinates; a fixed root's pose is the
        # frame of its joint in the world (moved with the env origin), and it does not move
        if layout.floating:
            self.root_pose_w = self._coords[:, :7]
            self.root_com_vel_w = self._dofs[:, :6]  # Newton: COM linear velocity and angular velocity, world
        else:
            self.root_pose_w = world_block(model.joint_X_p, n, 7)[:, layout.joints.start]
            self.root_com_vel_w = torch.zeros(n, 6, device=self.device)
        self.root_pos_w = self.root_pose_w[:, :3]
        self.root_quat_w = self.root_pose_w[:, 3:7]
        self.root_lin_vel_w = self.root_com_vel_w[:, :3]
        self.root_ang_vel_w = self.root_com_vel_w[:, 3:6]
        # -- bodies
        self.body_pose_w = world_block(state.body_q, n, 7)[:, layout.bodies]
        self.body_vel_w = world_block(state.body_qd, n, 6)[:, layout.bodies]  # COM lin vel, ang vel
        self.body_wrench_w = world_block(state.body_f, n, 6)[:, layout.bodies]
        """External wrench on each body's COM (force [N], torque [N·m]; world frame). The solver applies it at
        every physics step until it is overwritten, so a disturbance persists between env steps."""
        self.body_com_b = world_block(model.body_com, n, 3)[:, layout.bodies]
        self.body_mass = wp.to_torch(model.body_mass).view(n, -1)[:, layout.bodies]
        self.body_inertia = world_block(model.body_inertia, n, 3, 3)[:, layout.bodies]  # about the COM
        self._body_inv_mass = wp.to_torch(model.body_inv_mass).view(n, -1)[:, layout.bodies]
        self._body_inv_inertia = world_block(model.body_inv_inertia, n, 3, 3)[:, layout.bodies]
        self.shape_ids, self.shape_body = self._shapes(model)
        """(N, S) global indices of the entity's shapes (world-major), for per-shape materials; (S,) the
        entity-local body of each of its shapes."""
        self._shape_color = None if model.shape_color is None else wp.to_torch(model.shape_color)
        """(all shapes, 3) the display colours cameras render (sRGB in [0, 1])."""
        # -- defaults (copies: what a reset returns to, relative to the env origin)
        self.default_body_mass = self.body_mass.clone()
        """Body masses as built [kg]: what each mass randomisation draws from (Isaac Lab)."""
        self.default_root_pose = self.root_pose_w.clone()
        # -- derived, refreshed by update()
        self.gravity_dir_w = torch.tensor(GRAVITY_DIR_W, device=self.device).expand(n, 3)
        self.root_lin_vel_b = torch.zeros(n, 3, device=self.device)
        self.root_ang_vel_b = torch.zeros(n, 3, device=self.device)
        self.projected_gravity_b = torch.zeros(n, 3, device=self.device)
        self.heading_w = torch.zeros(n, device=self.device)
        self._body_acc_w = torch.zeros(n, self.num_bodies, 6, device=self.device)
        self.body_lin_acc_w = self._body_acc_w[..., :3]
        """COM linear acceleration of each body [m/s²], world frame, by finite difference over the env step."""
        self.body_ang_acc_w = self._body_acc_w[..., 3:]
        """Angular acceleration of each body [rad/s²], world frame, by finite difference over the env step."""
        self._prev_body_vel_w = self.body_vel_w.clone()
        self._body_acc_valid = torch.zeros(n, 1, 1, dtype=torch.bool, device=self.device)
        # Warp views of the same memory, made once: update() refreshes the derived root quantities in one kernel
        # (twice per env step: after physics and after the resets) instead of ~40 small torch kernels
        self._root_state_wp = [wp.from_torch(self.root_pose_w), wp.from_torch(self.root_com_vel_w)]
        self._root_frames_args = [*self._root_state_wp, wp.vec3(*GRAVITY_DIR_W)] + [
            wp.from_torch(t) for t in (self.root_lin_vel_b, self.root_ang_vel_b, self.projected_gravity_b,
                                       self.heading_w)]
        self._reset_root_defaults_wp = [wp.from_torch(self.default_root_pose), wp.from_torch(self.env_origins)]
        self.wp_device = model.device
        """The Warp device of the simulation (where kernels on this entity's arrays launch)."""

    def _shapes(self, model: newton.Model) -> tuple[torch.Tensor, torch.Tensor]:
        """(N, S) global indices of the entity's shapes, world-major, and (S,) the entity-local body of each."""
        bodies_per_world = model.body_count // model.world_count
        shape_body = model.shape_body.numpy()
        world = shape_body // bodies_per_world
        local = shape_body % bodies_per_world - self.layout.bodies.start
        mine = (shape_body >= 0) & (local >= 0) & (local < self.num_bodies)
        ids = mine.nonzero()[0]
        ids = ids[np.argsort(world[ids], kind="stable")].reshape(self.num_envs, -1)  # each world's in model order
        return (torch.as_tensor(ids, dtype=torch.long, device=self.device),
                torch.as_tensor(local[ids[0]], dtype=torch.long, device=self.device))

    def set_color(self, color_rgb: torch.Tensor, env_mask: torch.Tensor) -> None:
        """Draw every shape of the entity in the masked envs in that env's colour, (N, 3) sRGB in [0, 1]: what
        cameras render from their next frame on (nothing physical changes)."""
        if self._shape_color is None:
            raise ValueError(f"entity '{self.name}': the model has no shape colours to set")
        if color_rgb.shape != (self.num_envs, 3):
            raise ValueError(f"entity '{self.name}': color_rgb of shape {tuple(color_rgb.shape)}, expected "
                             f"({self.num_envs}, 3)")
        ids = self.shape_ids[env_mask]  # (M, S)
        self._shape_color[ids] = color_rgb[env_mask].to(self._shape_color).unsqueeze(1).expand(-1, ids.shape[1], 3)

    @property
    def root_pos_env(self) -> torch.Tensor:
        """Root position relative to the env origin [m] (the env frame: world axes, origin at the env's);
        computed when read, as few terms need it."""
        return self.root_pos_w - self.env_origins

    # -- selection ------------------------------------------------------------------------------

    def find_bodies(self, exprs: str | Sequence[str], preserve_order: bool = False) -> tuple[list[int], list[str]]:
        return resolve_names(exprs, self.body_names, f"body of '{self.name}'", preserve_order)

    # -- derived quantities ---------------------------------------------------------------------

    def update(self) -> None:
        """Refresh derived quantities from the state; once per env step, after physics or a reset: the root's
        velocities and gravity in its frame, its heading."""
        wp.launch(_root_frames, dim=self.num_envs, inputs=self._root_frames_args, device=self.wp_device)

    def update_accelerations(self) -> None:
        """Body accelerations by finite difference over the env step; once per env step, after physics."""
        # a root-state write (reset, push) makes the previous velocity meaningless: report 0 for that step
        body_acc_w = (self.body_vel_w - self._prev_body_vel_w) / self._step_dt_s
        self._body_acc_w.copy_(torch.where(self._body_acc_valid, body_acc_w, 0.0))
        self._prev_body_vel_w[:] = self.body_vel_w
        self._body_acc_valid.fill_(True)

    def state_is_valid(self, max_joint_speed_rad_s: float) -> torch.Tensor:
        """(N,) bool: root state finite (no blow-up); articulations add their joints."""
        return torch.isfinite(self.root_pose_w).all(-1) & torch.isfinite(self.root_com_vel_w).all(-1)

    # -- writes (masked, no host sync) -----------------------------------------------------------

    def write_root_state(self, pose_w: torch.Tensor, com_vel_w: torch.Tensor, mask: torch.Tensor) -> None:
        """Set root pose (N,7) and root COM velocity (N,6, world frame) where mask (N,) is True. A fixed root
        takes the pose (its place in the env) and ignores the velocity. Call `Simulation.forward` after."""
        m = mask.unsqueeze(-1)
        self.root_pose_w.copy_(torch.where(m, pose_w, self.root_pose_w))
        if not self.is_fixed_base:
            self.root_com_vel_w.copy_(torch.where(m, com_vel_w, self.root_com_vel_w))
        self._body_acc_valid.masked_fill_(mask.view(-1, 1, 1), False)

    def write_root_state_env(self, pose_env: torch.Tensor, com_vel_w: torch.Tensor, mask: torch.Tensor) -> None:
        """`write_root_state` with the position relative to the env origin."""
        pose = pose_env.clone()
        pose[:, :3] += self.env_origins
        self.write_root_state(pose, com_vel_w, mask)

    def body_yaw_in_frame(self, body_ids: torch.Tensor | slice, frame_body_ids: torch.Tensor) -> torch.Tensor:
        """(N, B) yaw [rad] of each body of `body_ids` in the frame of the body `frame_body_ids` (1,): see
        `body_yaw_in_frame`."""
        return body_yaw_in_frame(self.body_pose_w, body_ids, frame_body_ids)

    def reset_root(self, pose_delta: torch.Tensor, com_vel_w: torch.Tensor, mask: torch.Tensor) -> None:
        """Where mask (N,) is True: the default root pose at the env origin, moved by pose_delta (N, 6: x, y, z
        [m], then roll, pitch, yaw [rad] turning the default orientation), with root COM velocity com_vel_w
        (N, 6, world frame); as `write_root_state` would be given them, in one kernel. Call `Simulation.forward`
        after."""
        inputs = [wp.from_torch(mask, dtype=wp.bool), *self._reset_root_defaults_wp,
                  wp.from_torch(pose_delta.contiguous()), wp.from_torch(com_vel_w.contiguous()),
                  int(not self.is_fixed_base), *self._root_state_wp]
        wp.launch(_reset_root, dim=self.num_envs, inputs=inputs, device=self.wp_device)
        self._body_acc_valid.masked_fill_(mask.view(-1, 1, 1), False)

    def reset_to_default(self, mask: torch.Tensor) -> None:
        """Default root pose at the env origin, at rest, where mask (N,) is True."""
        self.write_root_state_env(self.default_root_pose, torch.zeros_like(self.root_com_vel_w), mask)

    def set_external_wrench(self, wrench_w: torch.Tensor, mask: torch.Tensor) -> None:
        """Set the external wrench (N, B, 6: force [N], torque [N·m], world frame, at each body's COM) where
        mask (N,) is True; the solver applies it at every physics step until it is changed or the env resets."""
        self.body_wrench_w.copy_(torch.where(mask.view(-1, 1, 1), wrench_w, self.body_wrench_w))

    def set_body_mass(self, mass_kg: torch.Tensor, mask: torch.Tensor, scale_inertia: bool = True) -> None:
        """Set body masses (N, B) where mask (N,) is True, keeping inverse mass and inertia consistent.

        With scale_inertia the inertia scales with the mass (same shape, different density), as Isaac Lab
        does. The caller notifies the solver (`ModelFlags.BODY_INERTIAL_PROPERTIES`).
        """
        m = mask.view(-1, 1)
        new_mass = torch.where(m, mass_kg, self.body_mass)
        if scale_inertia:
            ratio = (new_mass / self.body_mass.clamp(min=1e-9)).unsqueeze(-1).unsqueeze(-1)
            self.body_inertia.mul_(ratio)
            self._body_inv_inertia.copy_(torch.where(ratio > 0, self._body_inv_inertia / ratio.clamp(min=1e-9), 0.0))
        self.body_mass.copy_(new_mass)
        self._body_inv_mass.copy_(torch.where(new_mass > 0, 1.0 / new_mass.clamp(min=1e-9), 0.0))


class RigidObject(Entity):
    """One rigid body replicated once per world: dynamic, kinematic (moved only by root-state writes) or fixed
    to the env. Its root is its body: `root_pose_w` is `body_pose_w[:, 0]` for a free object."""

    num_joints = 0
    joint_names: list[str] = []

    def __init__(self, name: str, model: newton.Model, state: newton.State, layout: EntityLayout,
                 body_names: list[str], step_dt_s: float, env_origins: torch.Tensor, body_type: str):
        super().__init__(name, model, state, layout, body_names, step_dt_s, env_origins)
        self.body_type = body_type
        """'dynamic', 'kinematic' or 'fixed' (RigidObjectCfg.body_type)."""

    def find_joints(self, exprs, preserve_order: bool = False):
        raise ValueError(f"'{self.name}' is a rigid object: it has no joints")
