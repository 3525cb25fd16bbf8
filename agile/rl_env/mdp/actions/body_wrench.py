"""What the training aids that push one body of the robot before every physics step share (`HarnessAction`,
`LiftAction`): the body's external-wrench slot, which random pushes write too, and the terrain height under a
height scanner."""

from __future__ import annotations

import torch
import warp as wp

from agile.rl_env.managers import ActionTerm


@wp.func
def write_body_wrench(i: int, body: int, aid_w: wp.spatial_vector, disturbance_w: wp.array(dtype=wp.spatial_vector),
                      body_f: wp.array(dtype=wp.spatial_vector), last_total_w: wp.array(dtype=wp.spatial_vector)):
    """Env i's aid wrench plus its current push into the body's slot of `state.body_f` (world frame, at the COM),
    remembered as what the aid wrote last."""
    total = disturbance_w[i] + aid_w
    body_f[body] = total
    last_total_w[i] = total


class BodyWrenchSlot:
    """The external wrench of one body in every env, written by an aid's kernel before every physics step (through
    `write_body_wrench`) and also by events (`apply_external_force_torque`) and resets.

    The solver applies `state.body_f` at every physics step, so the body's wrench is the push plus the aid:
    `update_disturbance`, once per env step before the physics, recovers the push as what the slot holds if that is
    no longer what the aid wrote last (an event or a reset wrote a new push), else keeps the previous push.
    """

    def __init__(self, env, entity, body_id: int):
        n, device = env.num_envs, env.device
        model = env.sim.model
        bodies_per_world = model.body_count // model.world_count
        self.global_body_ids = (torch.arange(n, device=device) * bodies_per_world + entity.layout.bodies.start
                                + body_id).to(torch.int32)
        """(N,) the body's index in the simulation state of each env's world."""
        self.disturbance_w = torch.zeros(n, 6, device=device)
        """(N, 6) the push an event wrote on the body (force [N], torque [N·m]; world frame)."""
        self.last_total_w = torch.zeros(n, 6, device=device)
        """(N, 6) the wrench the aid's kernel wrote last: push plus aid."""
        self.body_wrench_w = entity.body_wrench_w[:, body_id]
        """(N, 6) the slot itself: a view of `state.body_f`."""
        # Warp views of the same memory, for the aid's kernel inputs
        self.global_body_ids_wp = wp.from_torch(self.global_body_ids, dtype=wp.int32)
        self.disturbance_w_wp = wp.from_torch(self.disturbance_w, dtype=wp.spatial_vector)
        self.last_total_w_wp = wp.from_torch(self.last_total_w, dtype=wp.spatial_vector)

    def update_disturbance(self) -> None:
        """Once per env step, before the physics: the current push (masked math, no host sync)."""
        unchanged = (self.body_wrench_w == self.last_total_w).all(dim=-1, keepdim=True)
        self.disturbance_w.copy_(torch.where(unchanged, self.disturbance_w, self.body_wrench_w))


class TerrainHeightUnder:
    """Mean terrain height under the height scanner `sensor_name` [m] in each env (0 without a scanner: the
    ground plane), refreshed once per env step, before the physics, from the scan of the last env step (the env
    updates its scanners once per env step)."""

    def __init__(self, env, sensor_name: str | None):
        self.scanner = env.scene[sensor_name] if sensor_name is not None else None
        self.ground_z_m = torch.zeros(env.num_envs, device=env.device)
        """(N,) mean terrain height under the scanner's rays [m]."""
        self.ground_z_m_wp = wp.from_torch(self.ground_z_m)

    def update(self) -> None:
        if self.scanner is not None:
            self.ground_z_m.copy_(self.scanner.hit_z_m.mean(dim=1))


class BodyAidAction(ActionTerm):
    """A training aid that pushes one body before every physics step (a Simulation hook launching `kernel` over the
    envs with `kernel_inputs`): no action dimensions, a strength `scale` in [0, 1] that a curriculum sets in place,
    the body's wrench slot (pushes add to the aid) and the terrain height under `height_sensor`. Subclasses set
    `kernel` and `kernel_inputs` in their constructor, then call `start_hook()`; `apply_actions` refreshes what
    the kernel reads once per env step."""

    kernel = None
    kernel_inputs: list

    def __init__(self, cfg, env, what: str):
        super().__init__(cfg, env)
        self.robot = env.scene[cfg.asset_name]
        ids, names = self.robot.find_bodies(cfg.body_name)
        if len(ids) != 1:
            raise ValueError(f"{what} body_name '{cfg.body_name}' must match one body, matched {names}")
        self.body_id = ids[0]
        self.terrain = TerrainHeightUnder(env, cfg.height_sensor)
        self.wrench_slot = BodyWrenchSlot(env, self.robot, self.body_id)
        self.scale = torch.ones(1, device=env.device)
        """Strength in [0, 1], set by a curriculum in place."""

    def start_hook(self) -> None:
        self.env.sim.add_physics_step_hook(self.apply_wrench)

    @property
    def action_dim(self) -> int:
        return 0

    def scale_forces(self, scale: torch.Tensor | float) -> None:
        """Set the strength (1: as configured, 0: off); a 0-dim tensor is copied on its device (no host sync)."""
        self.scale.copy_(torch.as_tensor(scale, dtype=torch.float32, device=self.scale.device).reshape(1))

    def process_actions(self, actions: torch.Tensor) -> None:
        pass  # no policy output

    def apply_wrench(self) -> None:
        """Before every physics step (a Simulation hook)."""
        wp.launch(self.kernel, dim=self.env.num_envs, inputs=self.kernel_inputs)
