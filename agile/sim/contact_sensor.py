"""Net contact forces on an entity's bodies, their recent history, air/contact times, and optionally the forces
from one other entity alone (Isaac Lab ContactSensor with `filter_prim_paths_expr`).

Forces come from Newton: SolverMuJoCo writes the force of every contact of a physics step (the `CONTACT_F`
solver observable) against a `newton.Contacts` buffer (MuJoCo's own contacts exported into it, or those of
Newton's collision pipeline), and `newton.sensors.SensorContact` sums them per sensing body. One Warp
kernel then shifts the histories and advances the air/contact clocks. Everything runs on fixed-size device
buffers, so the update can live inside the captured decimation loop.
"""

from __future__ import annotations

import newton
import torch
import warp as wp

from agile.sim.entities.entity import Entity
from agile.sim.names import resolve_names
from agile.sim.scene_cfg import ContactSensorCfg


@wp.kernel
def _update_contact_buffers(
    total_force: wp.array(dtype=wp.vec3),
    body_qd: wp.array(dtype=wp.spatial_vector),
    sensing_body_ids: wp.array(dtype=wp.int32),
    force_threshold_n: float,
    dt_s: float,
    net_forces_w_history: wp.array3d(dtype=wp.vec3),
    lin_vel_w_history: wp.array3d(dtype=wp.vec3),
    current_air_time_s: wp.array2d(dtype=float),
    current_contact_time_s: wp.array2d(dtype=float),
    last_air_time_s: wp.array2d(dtype=float),
    last_contact_time_s: wp.array2d(dtype=float),
):
    env, body = wp.tid()
    row = env * net_forces_w_history.shape[2] + body
    force = total_force[row]
    history_length = net_forces_w_history.shape[1]
    for k in range(history_length - 1):
        h = history_length - 1 - k
        net_forces_w_history[env, h, body] = net_forces_w_history[env, h - 1, body]
        lin_vel_w_history[env, h, body] = lin_vel_w_history[env, h - 1, body]
    net_forces_w_history[env, 0, body] = force
    lin_vel_w_history[env, 0, body] = wp.spatial_top(body_qd[sensing_body_ids[row]])

    # Isaac Lab's clocks: a phase's duration is recorded at the step that ends it, including that step
    air = current_air_time_s[env, body]
    contact = current_contact_time_s[env, body]
    if wp.length(force) > force_threshold_n:
        if air > 0.0:
            last_air_time_s[env, body] = air + dt_s
        current_air_time_s[env, body] = 0.0
        current_contact_time_s[env, body] = contact + dt_s
    else:
        if contact > 0.0:
            last_contact_time_s[env, body] = contact + dt_s
        current_contact_time_s[env, body] = 0.0
        current_air_time_s[env, body] = air + dt_s


class ContactSensor:
    """Contact state of selected bodies of one entity in every world, refreshed every physics step.

    Torch views (zero-copy, world frame, forces in N, velocities in m/s, times in s):
    - `net_forces_w` (N, B, 3): net contact force of the last physics step.
    - `net_forces_w_history` (N, H, B, 3): the last H physics steps, newest first.
    - `lin_vel_w_history` (N, H, B, 3): the bodies' COM linear velocity at the same steps (for touchdown speed).
    - `current_air_time_s`, `current_contact_time_s`, `last_air_time_s`, `last_contact_time_s` (N, B):
      only with `track_air_time`.
    - `force_matrix_w` (N, B, M, 3): with a filter, the force on each body from each of the M filter shapes
      (the filter entity's shapes on its selected bodies, or the one ground shape) at the last physics step.
    A body is in contact when |net force| > `force_threshold_n`.
    """

    def __init__(self, cfg: ContactSensorCfg, model: newton.Model, solver: newton.solvers.SolverMuJoCo,
                 contacts: newton.Contacts, entity: Entity, filter_shape_ids: list[int] | None, physics_dt_s: float,
                 solver_observables=None):
        """`filter_shape_ids`: global shape indices of the filter (all worlds), or None for net forces only.
        `solver_observables`: another sensor's, to share (the solver fills one set per step); None makes them."""
        if cfg.history_length < 1:
            raise ValueError(f"history_length must be >= 1, got {cfg.history_length}")
        local_ids, self.body_names = entity.find_bodies(cfg.body_names)
        self.cfg = cfg
        self.num_envs = n = model.world_count
        self.num_bodies = b = len(local_ids)
        self.history_length = cfg.history_length
        self.track_air_time = cfg.track_air_time
        self.contacts = contacts
        """The buffer the solver exports each step's contacts into; pass it to `solver.step`."""
        self._physics_dt_s = physics_dt_s
        self._device = model.device

        world_start = model.body_world_start.numpy()
        first = entity.layout.bodies.start
        global_ids = [int(world_start[w]) + first + i for w in range(n) for i in local_ids]
        self._newton_sensor = newton.sensors.SensorContact(model, sensing_bodies=global_ids,
                                                           counterpart_shapes=filter_shape_ids,
                                                           request_contact_attributes=False)
        if list(self._newton_sensor.sensing_indices) != global_ids:
            raise RuntimeError("newton SensorContact reordered the sensing bodies; rows would not match (env, body)")
        self.solver_observables = solver_observables or solver.observables(
            kinds=self._newton_sensor.solver_observable_kinds, contacts=contacts)
        """Pass to `solver.step` so that it fills the contact forces."""
        self._sensing_body_ids = wp.array(global_ids, dtype=wp.int32, device=self._device)

        h = self.history_length
        self._forces_history = wp.zeros((n, h, b), dtype=wp.vec3, device=self._device)
        self._vel_history = wp.zeros((n, h, b), dtype=wp.vec3, device=self._device)
        self._times = [wp.zeros((n, b), dtype=float, device=self._device) for _ in range(4)]
        self.net_forces_w_history = wp.to_torch(self._forces_history)
        self.net_forces_w = self.net_forces_w_history[:, 0]
        self.lin_vel_w_history = wp.to_torch(self._vel_history)
        self._current_air, self._current_contact, self._last_air, self._last_contact = (
            wp.to_torch(a) for a in self._times)
        self.force_matrix_w: torch.Tensor | None = None
        if filter_shape_ids is not None:
            matrix = self._newton_sensor.force_matrix
            self.force_matrix_w = wp.to_torch(matrix).view(n, b, matrix.shape[1], 3)

    # -- selection ------------------------------------------------------------------------------

    def find_bodies(self, exprs, preserve_order: bool = False) -> tuple[list[int], list[str]]:
        """Indices into this sensor's bodies (not the robot's) of the bodies matching `exprs`."""
        return resolve_names(exprs, self.body_names, "contact sensor body", preserve_order)

    # -- air and contact time -------------------------------------------------------------------

    def _timing(self, tensor: torch.Tensor) -> torch.Tensor:
        if not self.track_air_time:
            raise RuntimeError("the contact sensor does not track air time: set ContactSensorCfg.track_air_time")
        return tensor

    @property
    def current_air_time_s(self) -> torch.Tensor:
        return self._timing(self._current_air)

    @property
    def current_contact_time_s(self) -> torch.Tensor:
        return self._timing(self._current_contact)

    @property
    def last_air_time_s(self) -> torch.Tensor:
        """Duration of the last completed flight phase, set at touchdown."""
        return self._timing(self._last_air)

    @property
    def last_contact_time_s(self) -> torch.Tensor:
        """Duration of the last completed stance phase, set at lift-off."""
        return self._timing(self._last_contact)

    def compute_first_contact(self, dt_s: float) -> torch.Tensor:
        """(N, B) bool: bodies that touched down within the last `dt_s` (pass the env step)."""
        # half a physics step of slack: the clock is a float sum of physics steps
        contact = self.current_contact_time_s
        return (contact > 0.0) & (contact < dt_s + 0.5 * self._physics_dt_s)

    def compute_first_air(self, dt_s: float) -> torch.Tensor:
        """(N, B) bool: bodies that lifted off within the last `dt_s` (pass the env step)."""
        air = self.current_air_time_s
        return (air > 0.0) & (air < dt_s + 0.5 * self._physics_dt_s)

    # -- per physics step and reset -------------------------------------------------------------

    def update(self, state: newton.State) -> None:
        """Read the contacts of the physics step just taken; call right after `solver.step`."""
        self._newton_sensor.update(None, self.contacts, observables=self.solver_observables)
        wp.launch(_update_contact_buffers, dim=(self.num_envs, self.num_bodies), device=self._device,
                  inputs=[self._newton_sensor.total_force, state.body_qd, self._sensing_body_ids,
                          self.cfg.force_threshold_n, self._physics_dt_s],
                  outputs=[self._forces_history, self._vel_history, *self._times])

    def _reading_tensors(self) -> dict[str, torch.Tensor]:
        tensors = {"net_forces_w_history": self.net_forces_w_history, "lin_vel_w_history": self.lin_vel_w_history,
                   "current_air_time_s": self._current_air, "current_contact_time_s": self._current_contact,
                   "last_air_time_s": self._last_air, "last_contact_time_s": self._last_contact}
        if self.force_matrix_w is not None:
            tensors["force_matrix_w"] = self.force_matrix_w
        return tensors

    def readings(self) -> dict[str, torch.Tensor]:
        """Copies of everything the sensor has read (force and velocity histories, the air and contact clocks, the
        force matrix): what `write_readings` puts back."""
        return {name: value.clone() for name, value in self._reading_tensors().items()}

    def write_readings(self, readings: dict[str, torch.Tensor]) -> None:
        """Put `readings()`'s values back in place (a replayed step reads what the recorded one read)."""
        targets = self._reading_tensors()
        if set(readings) != set(targets):
            raise ValueError(f"contact sensor readings {sorted(readings)}, this sensor reads {sorted(targets)}")
        for name, value in readings.items():
            targets[name].copy_(value)

    def reset(self, mask: torch.Tensor) -> None:
        """Clear histories and clocks where mask (N,) is True (masked in place, no host sync)."""
        m = mask.view(-1, 1)
        self.net_forces_w_history.masked_fill_(m.view(-1, 1, 1, 1), 0.0)
        self.lin_vel_w_history.masked_fill_(m.view(-1, 1, 1, 1), 0.0)
        for times in (self._current_air, self._current_contact, self._last_air, self._last_contact):
            times.masked_fill_(m, 0.0)
        if self.force_matrix_w is not None:
            self.force_matrix_w.masked_fill_(m.view(-1, 1, 1, 1), 0.0)
