"""Explicit actuators: torques computed every physics step by `newton.actuators` and written to joint_f.

Ideal PD, DC motor (torque-speed saturation) and delayed DC motor (a per-env delay, redrawn at every
reset, on position, velocity and effort setpoints). The composition delay -> PD drive -> clamp is
Newton's `Actuator`; this module only builds it per actuator group and adds the per-env delay draw.
"""

from __future__ import annotations

import newton
import torch
import warp as wp
from newton.actuators import Actuator, ClampingDCMotor, ClampingMaxEffort, Delay, DrivePD

from agile.actuators.implicit import ImplicitActuatorCfg, JointValue
from agile.utils.config import configclass


@configclass
class IdealPDActuatorCfg(ImplicitActuatorCfg):
    """τ = kp·(q* − q) + kd·(q̇* − q̇) + τ_ff, clipped to ±effort_limit, computed explicitly."""


@configclass
class DCMotorCfg(IdealPDActuatorCfg):
    """Ideal PD whose torque is bounded by the motor's torque-speed line:
    τ_max = min(τ_sat·(1 − q̇/v_lim), τ_lim), τ_min = max(τ_sat·(−1 − q̇/v_lim), −τ_lim)."""

    saturation_effort: JointValue | None = None  # τ_sat [N·m], stall torque


@configclass
class DelayedDCMotorCfg(DCMotorCfg):
    """DC motor whose setpoints arrive a number of physics steps late, drawn per env from
    [min_delay, max_delay] at every reset."""

    min_delay: int = 0  # [physics steps]
    max_delay: int = 0  # [physics steps]


@wp.kernel
def _zero_at(indices: wp.array[wp.uint32], a: wp.array[float], b: wp.array[float]):
    i = wp.tid()
    a[indices[i]] = 0.0
    b[indices[i]] = 0.0


class ExplicitActuatorGroup:
    """One actuator group of a replicated robot: a Newton `Actuator` over its DoFs in every world.

    Parameter tensors are (num_envs, group joints), world-major like the Newton arrays they back, so a
    write (domain randomisation, a new delay) reaches the actuator without a copy.
    """

    def __init__(self, name: str, cfg: IdealPDActuatorCfg, joint_ids: list[int], values: dict[str, torch.Tensor],
                 state: newton.State, control: newton.Control, computed_effort: wp.array, num_envs: int,
                 device: torch.device):
        self.name = name
        self.cfg = cfg
        self.joint_id_list = list(joint_ids)
        self.joint_ids = torch.tensor(joint_ids, dtype=torch.long, device=device)
        n, j = num_envs, len(joint_ids)
        dofs_per_world = state.joint_qd.shape[0] // n
        coords_per_world = state.joint_q.shape[0] // n
        world = torch.arange(n, device=device).unsqueeze(1)
        local = self.joint_ids.unsqueeze(0)
        dof_idx = (world * dofs_per_world + 6 + local).flatten().to(torch.int32)
        coord_idx = (world * coords_per_world + 7 + local).flatten().to(torch.int32)
        self._dof_idx = wp.from_torch(dof_idx, dtype=wp.uint32)
        self._coord_idx = wp.from_torch(coord_idx, dtype=wp.uint32)
        self._keep = (dof_idx, coord_idx)

        def param(key: str) -> torch.Tensor:
            return values[key].to(device=device, dtype=torch.float32).expand(n, j).contiguous()

        self.stiffness = param("stiffness")
        self.damping = param("damping")
        self.effort_limit = param("effort_limit")
        drive = DrivePD(kp=wp.from_torch(self.stiffness.view(-1)), kd=wp.from_torch(self.damping.view(-1)))
        if isinstance(cfg, DCMotorCfg):
            self.saturation_effort = param("saturation_effort")
            self.velocity_limit = param("velocity_limit")
            clamping = [ClampingDCMotor(saturation_effort=wp.from_torch(self.saturation_effort.view(-1)),
                                        velocity_limit=wp.from_torch(self.velocity_limit.view(-1)),
                                        max_motor_effort=wp.from_torch(self.effort_limit.view(-1)))]
        else:
            clamping = [ClampingMaxEffort(max_effort=wp.from_torch(self.effort_limit.view(-1)))]
        self.min_delay = int(getattr(cfg, "min_delay", 0))
        self.max_delay = int(getattr(cfg, "max_delay", 0))
        if not 0 <= self.min_delay <= self.max_delay:
            raise ValueError(f"actuator group '{name}': need 0 <= min_delay <= max_delay, "
                             f"got {self.min_delay}, {self.max_delay}")
        delay = None
        self.delay_steps = None
        if self.max_delay > 0:
            self.delay_steps = torch.full((n, j), self.max_delay, dtype=torch.int32, device=device)
            delay = Delay(delay_steps=wp.from_torch(self.delay_steps.view(-1)), max_delay=self.max_delay)
        self.actuator = Actuator(indices=self._dof_idx, pos_indices=self._coord_idx, drive=drive, delay=delay,
                                 clamping=clamping, control_computed_output_attr="computed_effort")
        self._sim_state = {"joint_q": state.joint_q, "joint_qd": state.joint_qd}
        self._sim_control = {"joint_target_q": control.joint_target_q, "joint_target_qd": control.joint_target_qd,
                             "joint_act": control.joint_act, "joint_f": control.joint_f,
                             "computed_effort": computed_effort}
        self._state_now = self.actuator.state()
        self._state_next = self.actuator.state()
        self._reset_mask = torch.zeros(n, j, dtype=torch.bool, device=device)
        self._reset_mask_wp = wp.from_torch(self._reset_mask.view(-1), dtype=wp.bool)

    def step(self, dt: float, substep: int, num_substeps: int) -> None:
        """One physics step: torques of this group into control.joint_f (Warp launches only, capturable)."""
        wp.launch(_zero_at, dim=self._dof_idx.shape[0],
                  inputs=[self._dof_idx, self._sim_control["joint_f"], self._sim_control["computed_effort"]])
        self.actuator.step(self._sim_state, self._sim_control, self._state_now, self._state_next, dt=dt)
        if self._state_now is None:
            return
        if substep == num_substeps - 1 and num_substeps % 2 == 1:
            # a captured loop bakes the Python swap: copy instead, so `_state_now` is current at every replay
            self._state_now.assign(self._state_next)
        else:
            self._state_now, self._state_next = self._state_next, self._state_now

    def after_physics(self) -> None:
        """Nothing to undo after the physics steps (the torques stay in joint_f for the rewards)."""

    def reset(self, env_mask: torch.Tensor) -> None:
        """Clear the delay buffers of the envs in env_mask and draw their new delays."""
        if self.delay_steps is None:
            return
        lag = torch.randint(self.min_delay, self.max_delay + 1, (env_mask.shape[0], 1), dtype=torch.int32,
                            device=env_mask.device)
        self.delay_steps.copy_(torch.where(env_mask.unsqueeze(-1), lag, self.delay_steps))
        self._reset_mask.copy_(env_mask.unsqueeze(-1).expand_as(self._reset_mask))
        self._state_now.reset(self._reset_mask_wp)
