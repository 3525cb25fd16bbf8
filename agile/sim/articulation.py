"""Zero-copy torch access to one replicated robot, and the one write path into its state."""

from __future__ import annotations

from collections.abc import Sequence

import newton
import torch
import warp as wp

from agile.sim.names import resolve_names
from agile.utils.math import quat_rotate_inverse, yaw_from_quat

GRAVITY_DIR_W = (0.0, 0.0, -1.0)


class Articulation:
    """A floating-base robot replicated once per world.

    Every tensor named `*_w`/`*_b` (world/body frame) is either a view of a Newton array
    (`root_pose_w`, `joint_pos`, `body_pose_w`, ...), so reading it costs nothing and writing it writes
    the simulation, or a derived quantity refreshed by `update()` once per env step.
    Quaternions are (x, y, z, w). Root linear velocities are those of the root link origin.
    """

    def __init__(self, model: newton.Model, state: newton.State, control: newton.Control,
                 joint_names: list[str], body_names: list[str], step_dt_s: float, computed_effort: wp.array,
                 soft_joint_pos_limit_factor: float = 1.0):
        n = model.world_count
        self.num_envs = n
        self.joint_names = list(joint_names)
        self.body_names = list(body_names)
        self.num_joints = len(joint_names)
        self.num_bodies = len(body_names)
        self.device = torch.device(wp.device_to_torch(model.device))
        self._model = model
        self._state = state
        self._step_dt_s = step_dt_s

        coords = wp.to_torch(state.joint_q).view(n, -1)
        dofs = wp.to_torch(state.joint_qd).view(n, -1)
        if coords.shape[1] - 7 != dofs.shape[1] - 6 or dofs.shape[1] - 6 != self.num_joints:
            raise ValueError(
                f"only robots with a free root joint and hinge/slide joints (one coordinate per DoF) are supported; "
                f"got {coords.shape[1]} coordinates and {dofs.shape[1]} DoFs per world for DoFs {self.joint_names}")
        # -- views of the state (one source of truth: the Newton arrays)
        self.root_pose_w = coords[:, :7]
        self.root_pos_w = coords[:, :3]
        self.root_quat_w = coords[:, 3:7]
        self.joint_pos = coords[:, 7:]
        self.root_com_vel_w = dofs[:, :6]  # Newton: COM linear velocity and angular velocity, world frame
        # Isaac Lab's root velocity (root_lin_vel_w = root_com_lin_vel_w) is the root body's centre-of-mass
        # velocity, not its frame origin's: they differ by w x r_com, up to 0.15 m/s at 1 rad/s when the centre
        # of mass is randomised
        self.root_lin_vel_w = dofs[:, :3]
        self.root_ang_vel_w = dofs[:, 3:6]
        self.joint_vel = dofs[:, 6:]
        self.body_pose_w = wp.to_torch(state.body_q).view(n, self.num_bodies, 7)
        self.body_vel_w = wp.to_torch(state.body_qd).view(n, self.num_bodies, 6)  # COM lin vel, ang vel
        self.body_wrench_w = wp.to_torch(state.body_f).view(n, self.num_bodies, 6)
        """External wrench on each body's COM (force [N], torque [N·m]; world frame). The solver applies it at
        every physics step until it is overwritten, so a disturbance persists between env steps."""
        # -- views of the control
        self.joint_pos_target = wp.to_torch(control.joint_target_q).view(n, -1)[:, 7:]
        self.joint_vel_target = wp.to_torch(control.joint_target_qd).view(n, -1)[:, 6:]
        self.joint_effort_target = wp.to_torch(control.joint_act).view(n, -1)[:, 6:]  # feedforward [N·m]
        self._explicit_torque = wp.to_torch(control.joint_f).view(n, -1)[:, 6:]
        self._explicit_computed_torque = wp.to_torch(computed_effort).view(n, -1)[:, 6:]
        self.explicit_joints = torch.zeros(self.num_joints, dtype=torch.bool, device=self.device)
        """Joints driven by explicit actuators (torques in joint_f) rather than the solver's implicit PD."""
        # -- views of per-world model parameters (domain randomisation writes these)
        self.joint_stiffness = wp.to_torch(model.joint_target_ke).view(n, -1)[:, 6:]
        self.joint_damping = wp.to_torch(model.joint_target_kd).view(n, -1)[:, 6:]
        self.joint_effort_limit = wp.to_torch(model.joint_effort_limit).view(n, -1)[:, 6:]
        self.joint_friction = wp.to_torch(model.joint_friction).view(n, -1)[:, 6:]  # dry friction [N·m]
        self.joint_armature = wp.to_torch(model.joint_armature).view(n, -1)[:, 6:]  # [kg·m²]
        self.joint_pos_limits = torch.stack(
            (wp.to_torch(model.joint_limit_lower).view(n, -1)[:, 6:],
             wp.to_torch(model.joint_limit_upper).view(n, -1)[:, 6:]), dim=-1)
        mid = self.joint_pos_limits.mean(dim=-1, keepdim=True)
        self.soft_joint_pos_limits = mid + (self.joint_pos_limits - mid) * soft_joint_pos_limit_factor
        """(N, J, 2) limits the position-limit penalty uses (Isaac Lab `soft_joint_pos_limits`) [rad]."""
        self.joint_vel_limit = wp.to_torch(model.joint_velocity_limit).view(n, -1)[:, 6:]
        self.body_com_b = wp.to_torch(model.body_com).view(n, self.num_bodies, 3)
        self.body_mass = wp.to_torch(model.body_mass).view(n, self.num_bodies)
        self.body_inertia = wp.to_torch(model.body_inertia).view(n, self.num_bodies, 3, 3)  # about the COM
        self._body_inv_mass = wp.to_torch(model.body_inv_mass).view(n, self.num_bodies)
        self._body_inv_inertia = wp.to_torch(model.body_inv_inertia).view(n, self.num_bodies, 3, 3)
        # -- defaults (copies: what a reset returns to)
        # world 0's joint parameters as built, before domain randomisation: what an exported policy's robot has
        self.nominal_joint_stiffness = self.joint_stiffness[0].clone()
        self.nominal_joint_damping = self.joint_damping[0].clone()
        self.nominal_joint_friction = self.joint_friction[0].clone()
        self.nominal_joint_armature = self.joint_armature[0].clone()
        self.default_body_mass = self.body_mass.clone()
        """Body masses as built [kg]: what each mass randomisation draws from (Isaac Lab)."""
        self.default_root_pose = self.root_pose_w.clone()
        self.default_joint_pos = self.joint_pos.clone()
        self.default_joint_vel = torch.zeros_like(self.joint_vel)
        # -- derived, refreshed by update()
        self.gravity_dir_w = torch.tensor(GRAVITY_DIR_W, device=self.device).expand(n, 3)
        self.root_lin_vel_b = torch.zeros(n, 3, device=self.device)
        self.root_ang_vel_b = torch.zeros(n, 3, device=self.device)
        self.projected_gravity_b = torch.zeros(n, 3, device=self.device)
        self.heading_w = torch.zeros(n, device=self.device)
        self.joint_acc = torch.zeros_like(self.joint_vel)
        self._prev_joint_vel = torch.zeros_like(self.joint_vel)
        self._body_acc_w = torch.zeros(n, self.num_bodies, 6, device=self.device)
        self.body_lin_acc_w = self._body_acc_w[..., :3]
        """COM linear acceleration of each body [m/s²], world frame, by finite difference over the env step."""
        self.body_ang_acc_w = self._body_acc_w[..., 3:]
        """Angular acceleration of each body [rad/s²], world frame, by finite difference over the env step."""
        self._prev_body_vel_w = self.body_vel_w.clone()
        self._body_acc_valid = torch.zeros(n, 1, 1, dtype=torch.bool, device=self.device)
        self.computed_torque = torch.zeros_like(self.joint_vel)
        """Joint torque the PD law asks for [N·m], before the effort limit."""
        self.applied_torque = torch.zeros_like(self.joint_vel)
        """Joint torque of the actuators [N·m]: the PD law clipped by the effort limit (an estimate for
        implicit PD, exact for explicit actuators)."""
        self.update()

    # -- selection ------------------------------------------------------------------------------

    def find_joints(self, exprs: str | Sequence[str], preserve_order: bool = False) -> tuple[list[int], list[str]]:
        return resolve_names(exprs, self.joint_names, "joint", preserve_order)

    def find_bodies(self, exprs: str | Sequence[str], preserve_order: bool = False) -> tuple[list[int], list[str]]:
        return resolve_names(exprs, self.body_names, "body", preserve_order)

    # -- derived quantities ---------------------------------------------------------------------

    def update(self) -> None:
        """Refresh derived quantities from the state; once per env step, after physics or a reset."""
        quat = self.root_quat_w
        self.root_lin_vel_b[:] = quat_rotate_inverse(quat, self.root_lin_vel_w)
        self.root_ang_vel_b[:] = quat_rotate_inverse(quat, self.root_ang_vel_w)
        self.projected_gravity_b[:] = quat_rotate_inverse(quat, self.gravity_dir_w)
        self.heading_w[:] = yaw_from_quat(quat)

    def update_accelerations(self) -> None:
        """Joint and body accelerations by finite difference over the env step; once per env step, after physics."""
        self.joint_acc[:] = (self.joint_vel - self._prev_joint_vel) / self._step_dt_s
        self._prev_joint_vel[:] = self.joint_vel
        # a root-state write (reset, push) makes the previous velocity meaningless: report 0 for that step
        body_acc_w = (self.body_vel_w - self._prev_body_vel_w) / self._step_dt_s
        self._body_acc_w.copy_(torch.where(self._body_acc_valid, body_acc_w, 0.0))
        self._prev_body_vel_w[:] = self.body_vel_w
        self._body_acc_valid.fill_(True)

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

    def set_explicit_joints(self, joint_ids: list[int]) -> None:
        self.explicit_joints.zero_()
        self.explicit_joints[joint_ids] = True

    def compute_pd_torque(self) -> None:
        """Refresh computed/applied torques: the explicit actuators' last physics step, and for implicit
        joints the PD law at the current state (clipped to the effort limit), as Isaac Lab estimates it."""
        estimate = self.joint_stiffness * (self.joint_pos_target - self.joint_pos) + \
            self.joint_damping * (self.joint_vel_target - self.joint_vel) + self.joint_effort_target
        clipped = torch.clamp(estimate, -self.joint_effort_limit, self.joint_effort_limit)
        torch.where(self.explicit_joints, self._explicit_computed_torque, estimate, out=self.computed_torque)
        torch.where(self.explicit_joints, self._explicit_torque, clipped, out=self.applied_torque)

    # -- writes (masked, no host sync) -----------------------------------------------------------

    def write_root_state(self, pose_w: torch.Tensor, com_vel_w: torch.Tensor, mask: torch.Tensor) -> None:
        """Set root pose (N,7) and root COM velocity (N,6, world frame) where mask (N,) is True."""
        m = mask.unsqueeze(-1)
        self.root_pose_w.copy_(torch.where(m, pose_w, self.root_pose_w))
        self.root_com_vel_w.copy_(torch.where(m, com_vel_w, self.root_com_vel_w))
        self._body_acc_valid.masked_fill_(mask.view(-1, 1, 1), False)

    def write_joint_state(self, pos: torch.Tensor, vel: torch.Tensor, mask: torch.Tensor) -> None:
        m = mask.unsqueeze(-1)
        self.joint_pos.copy_(torch.where(m, pos, self.joint_pos))
        self.joint_vel.copy_(torch.where(m, vel, self.joint_vel))
        self._prev_joint_vel.copy_(torch.where(m, vel, self._prev_joint_vel))
        self.joint_acc.masked_fill_(m, 0.0)
