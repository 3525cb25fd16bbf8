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

from agile.actuators.group import ActuatorGroup
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


class ExplicitActuatorGroup(ActuatorGroup):
    """One actuator group of a replicated robot: a Newton `Actuator` over its DoFs in every world.

    Parameter tensors are (num_envs, group joints), world-major like the Newton arrays they back, so a
    write (domain randomisation, a new delay) reaches the actuator without a copy.
    """

    def __init__(self, name: str, cfg: IdealPDActuatorCfg, joint_ids: list[int], coord_ids: torch.Tensor,
                 dof_ids: torch.Tensor, values: dict[str, torch.Tensor], state: newton.State, control: newton.Control,
                 computed_effort: wp.array, num_envs: int, device: torch.device):
        super().__init__(name, cfg, joint_ids, coord_ids, dof_ids, num_envs, device,
                         int(getattr(cfg, "min_delay", 0)), int(getattr(cfg, "max_delay", 0)))
        n, j = num_envs, len(joint_ids)

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
        delay = None
        if self.delay_steps is not None:
            delay = Delay(delay_steps=wp.from_torch(self.delay_steps.view(-1)), max_delay=self.max_delay)
        self.actuator = Actuator(indices=self._dofs, pos_indices=self._coords, drive=drive, delay=delay,
                                 clamping=clamping, control_computed_output_attr="computed_effort")
        self._sim_state = {"joint_q": state.joint_q, "joint_qd": state.joint_qd}
        self._sim_control = {"joint_target_q": control.joint_target_q, "joint_target_qd": control.joint_target_qd,
                             "joint_act": control.joint_act, "joint_f": control.joint_f,
                             "computed_effort": computed_effort}
        self._state_now = self.actuator.state()
        self._state_next = self.actuator.state()

    def step(self, dt: float, substep: int, num_substeps: int) -> None:
        """One physics step: torques of this group into control.joint_f (Warp launches only, capturable)."""
        wp.launch(_zero_at, dim=self._dofs.shape[0],
                  inputs=[self._dofs, self._sim_control["joint_f"], self._sim_control["computed_effort"]])
        self.actuator.step(self._sim_state, self._sim_control, self._state_now, self._state_next, dt=dt)
        self._advance_state(substep, num_substeps)
