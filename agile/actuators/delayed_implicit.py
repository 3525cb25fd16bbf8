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


class DelayedTargetGroup:
    """Delays the targets of one implicit-PD actuator group in every world.

    At the first physics step of a `Simulation.step` it takes the setpoints from the control (where the
    action terms wrote them), at every physics step it writes the delayed setpoints there for the solver,
    and after the last one it puts the setpoints back, so that between env steps the control holds what
    was commanded.
    """

    def __init__(self, name: str, cfg: DelayedImplicitActuatorCfg, joint_ids: list[int], control: newton.Control,
                 num_envs: int, device: torch.device):
        if not 0 <= cfg.min_delay <= cfg.max_delay or cfg.max_delay < 1:
            raise ValueError(f"actuator group '{name}': need 0 <= min_delay <= max_delay and max_delay >= 1, "
                             f"got {cfg.min_delay}, {cfg.max_delay}")
        self.name = name
        self.cfg = cfg
        self.min_delay, self.max_delay = cfg.min_delay, cfg.max_delay
        self.joint_ids = torch.tensor(joint_ids, dtype=torch.long, device=device)
        n, j = num_envs, len(joint_ids)
        world = torch.arange(n, device=device).unsqueeze(1)
        local = self.joint_ids.unsqueeze(0)
        dofs_per_world = control.joint_target_qd.shape[0] // n
        coords_per_world = control.joint_target_q.shape[0] // n
        self._idx = ((world * coords_per_world + 7 + local).flatten().to(torch.int32),
                     (world * dofs_per_world + 6 + local).flatten().to(torch.int32),
                     torch.arange(n * j, dtype=torch.int32, device=device))
        self._coords, self._dofs, self._seq = (wp.from_torch(t, dtype=wp.uint32) for t in self._idx)
        self._control = control
        self._command_q = wp.zeros(n * j, dtype=float, device=control.joint_target_q.device)
        self._command_qd = wp.zeros_like(self._command_q)
        self.delay_steps = torch.full((n, j), self.max_delay, dtype=torch.int32, device=device)
        self.delay = Delay(delay_steps=wp.from_torch(self.delay_steps.view(-1)), max_delay=self.max_delay)
        self.delay.finalize(self._command_q.device, n * j)
        self._state_now = self.delay.state(n * j, self._command_q.device)
        self._state_next = self.delay.state(n * j, self._command_q.device)
        self._reset_mask = torch.zeros(n, j, dtype=torch.bool, device=device)
        self._reset_mask_wp = wp.from_torch(self._reset_mask.view(-1), dtype=wp.bool)

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
        if substep == num_substeps - 1 and num_substeps % 2 == 1:
            self._state_now.assign(self._state_next)  # keep `_state_now` current across graph replays
        else:
            self._state_now, self._state_next = self._state_next, self._state_now

    def after_physics(self) -> None:
        c = self._control
        wp.launch(_scatter, dim=self._command_q.shape[0], inputs=[self._coords, self._dofs, self._command_q,
                                                                  self._command_qd, c.joint_target_q, c.joint_target_qd])

    def reset(self, env_mask: torch.Tensor) -> None:
        lag = torch.randint(self.min_delay, self.max_delay + 1, (env_mask.shape[0], 1), dtype=torch.int32,
                            device=env_mask.device)
        self.delay_steps.copy_(torch.where(env_mask.unsqueeze(-1), lag, self.delay_steps))
        self._reset_mask.copy_(env_mask.unsqueeze(-1).expand_as(self._reset_mask))
        self._state_now.reset(self._reset_mask_wp)
