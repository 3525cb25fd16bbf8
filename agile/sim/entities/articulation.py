"""An articulation: an entity with joints and its own actuator groups."""

from __future__ import annotations

from collections.abc import Sequence

import newton
import torch
import warp as wp

from agile.actuators import DelayedImplicitActuatorCfg, DelayedTargetGroup, ExplicitActuatorGroup, is_explicit
from agile.sim.entities.entity import Entity, EntityLayout
from agile.sim.names import resolve_names, resolve_values
from agile.sim.scene_cfg import ArticulationCfg


class Articulation(Entity):
    """A robot (floating or fixed base) replicated once per world: root and bodies as `Entity`, plus joint
    views (state, targets, per-world parameters) and the actuator groups that drive its joints."""

    def __init__(self, name: str, cfg: ArticulationCfg, model: newton.Model, state: newton.State,
                 control: newton.Control, layout: EntityLayout, joint_names: list[str], body_names: list[str],
                 step_dt_s: float, env_origins: torch.Tensor, computed_effort: wp.array):
        super().__init__(name, model, state, layout, body_names, step_dt_s, env_origins)
        n = model.world_count
        self.cfg = cfg
        self.joint_names = list(joint_names)
        self.num_joints = len(joint_names)
        # joint c of this articulation is coordinate coord0 + c and DoF dof0 + c of its world
        self._coord0 = layout.coords.start + (7 if layout.floating else 0)
        self._dof0 = layout.dofs.start + (6 if layout.floating else 0)
        coords = wp.to_torch(state.joint_q).view(n, -1)
        dofs = wp.to_torch(state.joint_qd).view(n, -1)
        self.coords_per_world, self.dofs_per_world = coords.shape[1], dofs.shape[1]
        if layout.coords.stop - self._coord0 != self.num_joints or layout.dofs.stop - self._dof0 != self.num_joints:
            raise ValueError(
                f"articulation '{name}': only hinge/slide joints (one coordinate per DoF) are supported below the "
                f"root; got {layout.coords} coordinates and {layout.dofs} DoFs for DoFs {self.joint_names}")
        joints = slice(self._coord0, layout.coords.stop)
        joint_dofs = slice(self._dof0, layout.dofs.stop)

        def per_dof(array: wp.array) -> torch.Tensor:
            return wp.to_torch(array).view(n, -1)[:, joint_dofs]

        # -- views of the state (one source of truth: the Newton arrays)
        self.joint_pos = coords[:, joints]
        self.joint_vel = dofs[:, joint_dofs]
        # -- views of the control
        self.joint_pos_target = wp.to_torch(control.joint_target_q).view(n, -1)[:, joints]
        self.joint_vel_target = per_dof(control.joint_target_qd)
        self.joint_effort_target = per_dof(control.joint_act)  # feedforward [N·m]
        self._explicit_torque = per_dof(control.joint_f)
        self._explicit_computed_torque = per_dof(computed_effort)
        self.explicit_joints = torch.zeros(self.num_joints, dtype=torch.bool, device=self.device)
        """Joints driven by explicit actuators (torques in joint_f) rather than the solver's implicit PD."""
        # -- views of per-world model parameters (domain randomisation writes these)
        self.joint_stiffness = per_dof(model.joint_target_ke)
        self.joint_damping = per_dof(model.joint_target_kd)
        self.joint_effort_limit = per_dof(model.joint_effort_limit)
        self.joint_friction = per_dof(model.joint_friction)  # dry friction [N·m]
        self.joint_armature = per_dof(model.joint_armature)  # [kg·m²]
        self.joint_pos_limits = torch.stack((per_dof(model.joint_limit_lower), per_dof(model.joint_limit_upper)), -1)
        mid = self.joint_pos_limits.mean(dim=-1, keepdim=True)
        self.soft_joint_pos_limits = mid + (self.joint_pos_limits - mid) * cfg.soft_joint_pos_limit_factor
        """(N, J, 2) limits the position-limit penalty uses (Isaac Lab `soft_joint_pos_limits`) [rad]."""
        self.joint_vel_limit = per_dof(model.joint_velocity_limit)
        self.joint_axis = wp.to_torch(model.joint_axis).view(n, -1, 3)[:, joint_dofs]
        """(N, J, 3) each joint's axis in its parent frame (the mirror functions read its signs)."""
        # world 0's joint parameters as built, before domain randomisation: what an exported policy's robot has
        self.nominal_joint_stiffness = self.joint_stiffness[0].clone()
        self.nominal_joint_damping = self.joint_damping[0].clone()
        self.nominal_joint_friction = self.joint_friction[0].clone()
        self.nominal_joint_armature = self.joint_armature[0].clone()
        self.default_joint_pos = self.joint_pos.clone()
        self.default_joint_vel = torch.zeros_like(self.joint_vel)
        self.joint_acc = torch.zeros_like(self.joint_vel)
        self._prev_joint_vel = torch.zeros_like(self.joint_vel)
        self.computed_torque = torch.zeros_like(self.joint_vel)
        """Joint torque the PD law asks for [N·m], before the effort limit."""
        self.applied_torque = torch.zeros_like(self.joint_vel)
        """Joint torque of the actuators [N·m]: the PD law clipped by the effort limit (an estimate for
        implicit PD, exact for explicit actuators)."""
        self.actuator_groups: list[ExplicitActuatorGroup | DelayedTargetGroup] = []
        """Per-physics-step actuator work of this articulation: explicit torque models and delayed targets."""
        for group_name, act in cfg.actuators.items():
            try:
                self._add_actuator_group(group_name, act, state, control, computed_effort)
            except ValueError as err:
                raise ValueError(f"actuator group '{group_name}': {err}") from None
        self.explicit_joints[[i for g in self.actuator_groups if isinstance(g, ExplicitActuatorGroup)
                              for i in g.joint_id_list]] = True
        self.update()

    def _add_actuator_group(self, group_name: str, act, state: newton.State, control: newton.Control,
                            computed_effort: wp.array) -> None:
        ids, names = self.find_joints(act.joint_names_expr)
        coord_ids, dof_ids = self.world_major_indices(ids)
        if isinstance(act, DelayedImplicitActuatorCfg):
            self.actuator_groups.append(DelayedTargetGroup(group_name, act, ids, coord_ids, dof_ids, control,
                                                           self.num_envs, self.device))
            return
        if not is_explicit(act):
            return
        values = {"stiffness": self.joint_stiffness[0, ids], "damping": self.joint_damping[0, ids],
                  "effort_limit": self.joint_effort_limit[0, ids], "velocity_limit": self.joint_vel_limit[0, ids]}
        if getattr(act, "saturation_effort", None) is not None:
            values["saturation_effort"] = torch.tensor(
                [v for _, v in sorted(resolve_values(act.saturation_effort, names).items())])
        elif hasattr(act, "saturation_effort"):
            raise ValueError("a DC motor needs saturation_effort")
        self.actuator_groups.append(ExplicitActuatorGroup(group_name, act, ids, coord_ids, dof_ids, values, state,
                                                          control, computed_effort, self.num_envs, self.device))

    def world_major_indices(self, joint_ids: list[int]) -> tuple[torch.Tensor, torch.Tensor]:
        """(num_envs * len(joint_ids),) int32 indices of the joints into Newton's coordinate- and DoF-shaped
        arrays, world-major (world 0's joints first), as Newton's actuators index them."""
        world = torch.arange(self.num_envs, device=self.device).unsqueeze(1)
        local = torch.tensor(joint_ids, dtype=torch.long, device=self.device).unsqueeze(0)
        coords = (world * self.coords_per_world + self._coord0 + local).flatten().to(torch.int32)
        dofs = (world * self.dofs_per_world + self._dof0 + local).flatten().to(torch.int32)
        return coords, dofs

    # -- selection ------------------------------------------------------------------------------

    def find_joints(self, exprs: str | Sequence[str], preserve_order: bool = False) -> tuple[list[int], list[str]]:
        return resolve_names(exprs, self.joint_names, f"joint of '{self.name}'", preserve_order)

    # -- derived quantities ---------------------------------------------------------------------

    def update_accelerations(self) -> None:
        """Joint and body accelerations by finite difference over the env step; once per env step, after physics."""
        self.joint_acc[:] = (self.joint_vel - self._prev_joint_vel) / self._step_dt_s
        self._prev_joint_vel[:] = self.joint_vel
        super().update_accelerations()

    def state_is_valid(self, max_joint_speed_rad_s: float) -> torch.Tensor:
        return super().state_is_valid(max_joint_speed_rad_s) & torch.isfinite(self.joint_pos).all(-1) & \
            (self.joint_vel.abs() <= max_joint_speed_rad_s).all(-1)

    def compute_pd_torque(self) -> None:
        """Refresh computed/applied torques: the explicit actuators' last physics step, and for implicit
        joints the PD law at the current state (clipped to the effort limit), as Isaac Lab estimates it."""
        estimate = self.joint_stiffness * (self.joint_pos_target - self.joint_pos) + \
            self.joint_damping * (self.joint_vel_target - self.joint_vel) + self.joint_effort_target
        clipped = torch.clamp(estimate, -self.joint_effort_limit, self.joint_effort_limit)
        torch.where(self.explicit_joints, self._explicit_computed_torque, estimate, out=self.computed_torque)
        torch.where(self.explicit_joints, self._explicit_torque, clipped, out=self.applied_torque)

    # -- writes (masked, no host sync) -----------------------------------------------------------

    def write_joint_state(self, pos: torch.Tensor, vel: torch.Tensor, mask: torch.Tensor) -> None:
        m = mask.unsqueeze(-1)
        self.joint_pos.copy_(torch.where(m, pos, self.joint_pos))
        self.joint_vel.copy_(torch.where(m, vel, self.joint_vel))
        self._prev_joint_vel.copy_(torch.where(m, vel, self._prev_joint_vel))
        self.joint_acc.masked_fill_(m, 0.0)

    def reset_to_default(self, mask: torch.Tensor) -> None:
        super().reset_to_default(mask)
        self.write_joint_state(self.default_joint_pos, self.default_joint_vel, mask)

    def reset_actuators(self, mask: torch.Tensor) -> None:
        """Clear actuator state (delay buffers) and draw new per-env delays where mask (N,) is True."""
        for group in self.actuator_groups:
            group.reset(mask)
