"""Delayed implicit PD: the solver's implicit PD acts on setpoints that arrive late.

A per-env delay, drawn from [min_delay, max_delay] physics steps at every reset, is applied to the
position and velocity targets of the group's joints before the solver sees them. The ring buffer is
Newton's `newton.actuators.Delay`; this module feeds it and writes its output back to the control.
"""

from __future__ import annotations

import newton
import torch
import warp as wp
from newton.actuators import Delay

from agile.actuators.group import ActuatorGroup
from agile.actuators.implicit import ImplicitActuatorCfg
from agile.utils.config import configclass


@configclass
class DelayedImplicitActuatorCfg(ImplicitActuatorCfg):
    min_delay: int = 0  # [physics steps]
    max_delay: int = 0  # [physics steps]


@wp.kernel
def _gather(coords: wp.array[wp.uint32], dofs: wp.array[wp.uint32], target_q: wp.array[float],
            target_qd: wp.array[float], out_q: wp.array[float], out_qd: wp.array[float]):
    i = wp.tid()
    out_q[i] = target_q[coords[i]]
    out_qd[i] = target_qd[dofs[i]]


@wp.kernel
def _scatter(coords: wp.array[wp.uint32], dofs: wp.array[wp.uint32], q: wp.array[float], qd: wp.array[float],
             target_q: wp.array[float], target_qd: wp.array[float]):
    i = wp.tid()
    target_q[coords[i]] = q[i]
    target_qd[dofs[i]] = qd[i]


class DelayedTargetGroup(ActuatorGroup):
    """Delays the targets of one implicit-PD actuator group in every world.

    At the first physics step of a `Simulation.step` it takes the setpoints from the control (where the
    action terms wrote them), at every physics step it writes the delayed setpoints there for the solver,
    and after the last one it puts the setpoints back, so that between env steps the control holds what
    was commanded.
    """

    def __init__(self, name: str, cfg: DelayedImplicitActuatorCfg, joint_ids: list[int], coord_ids: torch.Tensor,
                 dof_ids: torch.Tensor, control: newton.Control, num_envs: int, device: torch.device):
        if cfg.max_delay < 1:
            raise ValueError(f"actuator group '{name}': a delayed implicit group needs max_delay >= 1")
        super().__init__(name, cfg, joint_ids, coord_ids, dof_ids, num_envs, device, cfg.min_delay, cfg.max_delay)
        count = num_envs * len(joint_ids)
        self._sequential = torch.arange(count, dtype=torch.int32, device=device)
        self._seq = wp.from_torch(self._sequential, dtype=wp.uint32)
        self._control = control
        wp_device = control.joint_target_q.device
        self._command_q = wp.zeros(count, dtype=float, device=wp_device)
        self._command_qd = wp.zeros_like(self._command_q)
        self.delay = Delay(delay_steps=wp.from_torch(self.delay_steps.view(-1)), max_delay=self.max_delay)
        self.delay.finalize(wp_device, count)
        self._state_now = self.delay.state(count, wp_device)
        self._state_next = self.delay.state(count, wp_device)

    def step(self, dt: float, substep: int, num_substeps: int) -> None:
        c = self._control
        count = self._command_q.shape[0]
        if substep == 0:
            wp.launch(_gather, dim=count, inputs=[self._coords, self._dofs, c.joint_target_q, c.joint_target_qd,
                                                  self._command_q, self._command_qd])
        q, qd, _ = self.delay.get_delayed_targets(self._command_q, self._command_qd, None, self._seq, self._seq,
                                                  self._state_now)
        wp.launch(_scatter, dim=count, inputs=[self._coords, self._dofs, q, qd, c.joint_target_q, c.joint_target_qd])
        self.delay.update_state(self._command_q, self._command_qd, None, self._seq, self._seq, self._state_now,
                                self._state_next)
        self._advance_state(substep, num_substeps)

    def after_physics(self) -> None:
        c = self._control
        wp.launch(_scatter, dim=self._command_q.shape[0], inputs=[self._coords, self._dofs, self._command_q,
                                                                  self._command_qd, c.joint_target_q, c.joint_target_qd])
