"""What every per-physics-step actuator group shares: its DoFs in every world, per-env delays drawn at
reset, and double-buffered Newton actuator states."""

from __future__ import annotations

import torch
import warp as wp


class ActuatorGroup:
    """Base of actuator groups. Subclasses create `_state_now`/`_state_next` and implement `step`."""

    def __init__(self, name: str, cfg, joint_ids: list[int], coord_ids: torch.Tensor, dof_ids: torch.Tensor,
                 num_envs: int, device: torch.device, min_delay: int = 0, max_delay: int = 0):
        """`coord_ids`, `dof_ids`: (num_envs * joints,) int32 world-major indices of the group's joints into
        coordinate- and DoF-shaped Newton arrays (`Articulation.world_major_indices`)."""
        if not 0 <= min_delay <= max_delay:
            raise ValueError(f"actuator group '{name}': need 0 <= min_delay <= max_delay, got {min_delay}, {max_delay}")
        self.name = name
        self.cfg = cfg
        self.joint_id_list = list(joint_ids)
        self.joint_ids = torch.tensor(joint_ids, dtype=torch.long, device=device)
        self.min_delay, self.max_delay = min_delay, max_delay
        n, j = num_envs, len(joint_ids)
        self._index_tensors = (coord_ids, dof_ids)
        self._coords, self._dofs = (wp.from_torch(t, dtype=wp.uint32) for t in self._index_tensors)
        self.delay_steps = torch.full((n, j), max_delay, dtype=torch.int32, device=device) if max_delay > 0 else None
        """Per-env delay [physics steps] of each joint, (num_envs, joints); redrawn at every reset."""
        self._reset_mask = torch.zeros(n, j, dtype=torch.bool, device=device)
        self._reset_mask_wp = wp.from_torch(self._reset_mask.view(-1), dtype=wp.bool)
        self._state_now = None
        self._state_next = None

    def _advance_state(self, substep: int, num_substeps: int) -> None:
        if self._state_now is None:
            return
        if substep == num_substeps - 1 and num_substeps % 2 == 1:
            # a captured loop bakes the Python swap: copy instead, so `_state_now` is current at every replay
            self._state_now.assign(self._state_next)
        else:
            self._state_now, self._state_next = self._state_next, self._state_now

    def after_physics(self) -> None:
        """Called once after the physics steps of a `Simulation.step`."""

    def reset(self, env_mask: torch.Tensor) -> None:
        """Clear the delay buffers of the envs in env_mask and draw their new delays (one per env)."""
        if self.delay_steps is None:
            return
        lag = torch.randint(self.min_delay, self.max_delay + 1, (env_mask.shape[0], 1), dtype=torch.int32,
                            device=env_mask.device)
        self.delay_steps.copy_(torch.where(env_mask.unsqueeze(-1), lag, self.delay_steps))
        self._reset_mask.copy_(env_mask.unsqueeze(-1).expand_as(self._reset_mask))
        self._state_now.reset(self._reset_mask_wp)
