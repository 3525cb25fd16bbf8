"""Peaks of the solver's fixed-size buffers, measured on the device every physics step.

MuJoCo Warp sizes its constraint rows (`njmax` per world) and contacts (`nconmax` per world, one pool for all
worlds) once; rows beyond `njmax` are dropped silently (the world steps without those constraints) and contacts
beyond the pool are lost (MuJoCo prints a line, nothing counts it). This tracks the demand, so that a task's
`njmax`/`nconmax` can be sized from measured peaks and an overflow shows in the training logs.
"""

from __future__ import annotations

import torch
import warp as wp


@wp.kernel(enable_backward=False)
def _track(rows_per_world: wp.array(dtype=int), njmax: int, contact_count: wp.array(dtype=int),
           peak_rows: wp.array(dtype=int), row_overflows: wp.array(dtype=int), peak_contacts: wp.array(dtype=int)):
    world = wp.tid()
    rows = rows_per_world[world]  # MuJoCo Warp counts every row a world asks for, also those past njmax
    wp.atomic_max(peak_rows, 0, rows)
    if rows > njmax:
        wp.atomic_add(row_overflows, 0, 1)
    if world == 0:
        wp.atomic_max(peak_contacts, 0, contact_count[0])


class PhysicsCapacity:
    """Device counters since construction (or `clear()`); torch views, read without a sync until you print them:

    - `peak_constraint_rows` (1,): the most constraint rows one world needed in one physics step; `njmax` the cap;
    - `constraint_row_overflows` (1,): world-steps that needed more than `njmax` rows;
    - `peak_contacts` (1,): the most contacts of all worlds together in one step; `contact_capacity` the pool.
    """

    def __init__(self, rows_per_world: wp.array, njmax: int, contact_count: wp.array, contact_capacity: int):
        self._rows_per_world = rows_per_world
        self.njmax = int(njmax)
        self._contact_count = contact_count
        self.contact_capacity = int(contact_capacity)
        self._counters = wp.zeros(3, dtype=int, device=rows_per_world.device)
        counters = wp.to_torch(self._counters)
        self.peak_constraint_rows = counters[0:1]
        self.constraint_row_overflows = counters[1:2]
        self.peak_contacts = counters[2:3]

    def update(self) -> None:
        """After each solver step (graph-capturable)."""
        wp.launch(_track, dim=self._rows_per_world.shape[0], device=self._rows_per_world.device,
                  inputs=[self._rows_per_world, self.njmax, self._contact_count],
                  outputs=[self._counters[0:1], self._counters[1:2], self._counters[2:3]])

    def clear(self) -> None:
        self._counters.zero_()

    def log(self) -> dict[str, torch.Tensor]:
        """Scalars for the training log (device tensors)."""
        return {"Physics/peak_constraint_rows_share_of_njmax": self.peak_constraint_rows[0] / self.njmax,
                "Physics/constraint_row_overflows": self.constraint_row_overflows[0].float(),
                "Physics/peak_contacts_share_of_capacity": self.peak_contacts[0] / self.contact_capacity}
