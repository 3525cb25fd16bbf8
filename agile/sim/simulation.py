"""The Newton world: N replicated worlds of the scene's entities on a ground plane or terrain, stepped by
SolverMuJoCo."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable

import mujoco_warp
import newton
import torch
import warp as wp

from agile.actuators import DelayedTargetGroup, ExplicitActuatorGroup
from agile.sim.camera import Camera
from agile.sim.capacity import PhysicsCapacity
from agile.sim.contact_sensor import ContactSensor
from agile.sim.height_scanner import HeightScanner, TerrainHeights
from agile.sim.scene import Scene, build_world_template, entity_of, filter_shape_ids, make_entities
from agile.sim.scene_cfg import SceneCfg
from agile.sim.sim_cfg import SimCfg, check_physics_cfg
from agile.sim.terrain import TerrainData, load_or_generate_terrain
from agile.sim.terrain_contacts import TerrainContacts, split_terrain_pairs
from agile.utils.config import ConfigError
from agile.utils.heap import no_collection_while_capturing


def env_origins_grid(num_envs: int, spacing_m: float, device) -> torch.Tensor:
    """(N, 3) origins on a square grid centred on the world origin."""
    cols = math.ceil(math.sqrt(num_envs))
    idx = torch.arange(num_envs, device=device)
    origins = torch.zeros(num_envs, 3, device=device)
    origins[:, 0] = (idx // cols).float() * spacing_m
    origins[:, 1] = (idx % cols).float() * spacing_m
    origins[:, :2] -= origins[:, :2].mean(dim=0, keepdim=True)
    return origins


def terrain_heightfield(terrain: TerrainData) -> newton.Heightfield:
    """The terrain as a Newton height field centred on the world origin (rows of `data` run along y)."""
    nx, ny = terrain.heights_m.shape
    h = terrain.horizontal_scale_m
    return newton.Heightfield(data=terrain.heights_m.T, nrow=ny, ncol=nx, hx=(nx - 1) * h / 2, hy=(ny - 1) * h / 2)


class Simulation:
    """Builds the replicated world and steps it; the decimation loop is one captured graph."""

    def __init__(self, cfg: SimCfg, scene_cfg: SceneCfg, num_envs: int, device: str, step_dt_s: float):
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        check_physics_cfg(cfg, scene_cfg)
        self.cfg = cfg
        self.scene_cfg = scene_cfg
        self.num_envs = num_envs
        self.wp_device = wp.get_device(device)
        self.device = torch.device(wp.device_to_torch(self.wp_device))
        self.physics_dt_s = cfg.physics_dt_s
        if self.wp_device.is_cuda:
            # one CUDA stream for Warp and torch: term math and physics stay ordered without host syncs,
            # and graph capture runs on a non-default stream
            torch.cuda.set_stream(wp.stream_to_torch(wp.get_stream(self.wp_device)))

        template, layouts, names = build_world_template(scene_cfg, cfg.gravity_mps2)
        world = newton.ModelBuilder(gravity=(0.0, 0.0, cfg.gravity_mps2))
        newton.solvers.SolverMuJoCo.register_custom_attributes(world)
        world.replicate(template, copy_count=num_envs, spacing=(0.0, 0.0, 0.0))
        ground_cfg = newton.ModelBuilder.ShapeConfig(mu=scene_cfg.ground_friction)
        self.terrain: TerrainData | None = None
        if scene_cfg.terrain is None:
            ground_shape = world.add_ground_plane(cfg=ground_cfg)
        else:
            self.terrain = load_or_generate_terrain(scene_cfg.terrain)
            self.terrain_cell_size_m = float(scene_cfg.terrain.size_m)
            """The side of one terrain cell (sub-terrain) [m]."""
            ground_shape = world.add_shape_heightfield(heightfield=terrain_heightfield(self.terrain), cfg=ground_cfg,
                                                       label="terrain")
        self.model = world.finalize(device=self.wp_device)
        if self.terrain is not None:
            self.model.shape_gap.fill_(scene_cfg.terrain_contact_gap_m)
        s = cfg.solver
        self.solver = newton.solvers.SolverMuJoCo(
            self.model, iterations=s.iterations, ls_iterations=s.ls_iterations, njmax=s.njmax, nconmax=s.nconmax,
            cone=s.cone, impratio=s.impratio, integrator=s.integrator, solver=s.solver,
            use_mujoco_contacts=self.terrain is None)
        # on a terrain we detect the contacts: mujoco_warp's height-field collision throws boxes (feet) off the
        # field (seen on CPU, mujoco_warp 3.17)
        self.collision_pipeline: newton.CollisionPipeline | None = None
        self.terrain_contacts: TerrainContacts | None = None
        self.contacts: newton.Contacts | None = None
        if self.terrain is not None:
            self._make_terrain_collision(scene_cfg.terrain_collision, ground_shape)
        mjw = self.solver.mjw_data
        self.capacity = PhysicsCapacity(
            mjw.nefc, s.njmax, mjw.nacon if self.contacts is None else self.contacts.rigid_contact_count,
            mjw.naconmax if self.contacts is None else self.contacts.rigid_contact_max)
        """Peak constraint rows and contacts, and `njmax` overflows, counted on the device every physics step."""
        # a capped iteration count is a deliberate speed/accuracy trade-off in RL: do not print a warning
        # from every world at every step when it is reached (capacity overflows still print)
        quiet = mujoco_warp.OverflowType.ITERATIONS | mujoco_warp.OverflowType.LS_ITERATIONS
        self.solver.mjw_model.opt.warn_overflow = int(self.solver.mjw_model.opt.warn_overflow) & ~int(quiet)
        self.state = self.model.state()
        self.control = self.model.control()
        self.computed_effort = wp.zeros_like(self.state.joint_qd)
        """Explicit actuators' torque before clipping, per DoF (their clipped torque is control.joint_f)."""
        self.env_origins = env_origins_grid(num_envs, scene_cfg.env_spacing_m, self.device)
        """(N, 3) spawn point of each env; changed in place when an env changes terrain level."""
        if self.terrain is not None:
            self._init_terrain_levels(scene_cfg.max_init_terrain_level)
        entities = make_entities(scene_cfg, self.model, self.state, self.control, layouts, names, step_dt_s,
                                 self.env_origins, self.computed_effort)
        self.actuator_groups: list[ExplicitActuatorGroup | DelayedTargetGroup] = [
            group for entity in entities.values() for group in getattr(entity, "actuator_groups", [])]
        """Per-physics-step actuator work of every articulation: explicit torque models and delayed targets."""
        contact_sensors = self._make_contact_sensors(scene_cfg, entities, ground_shape)
        terrain_heights = None if self.terrain is None else TerrainHeights(
            torch.from_numpy(self.terrain.heights_m).to(self.device), self.terrain.origin_xy_m,
            self.terrain.horizontal_scale_m)
        height_scanners: dict[str, HeightScanner] = {}
        for name, scanner_cfg in scene_cfg.height_scanners.items():
            where = f"scene.height_scanners.{name}"
            entity = entity_of(entities, scanner_cfg.entity, f"{where}.entity")
            try:
                height_scanners[name] = HeightScanner(scanner_cfg, entity, terrain_heights)
            except ValueError as err:
                raise ConfigError(f"{where}: {err}") from None
        cameras: dict[str, Camera] = {}
        for name, camera_cfg in scene_cfg.cameras.items():
            where = f"scene.cameras.{name}"
            entity = entity_of(entities, camera_cfg.entity, f"{where}.entity")
            try:
                cameras[name] = Camera(camera_cfg, entity, self.model)
            except ValueError as err:
                raise ConfigError(f"{where}: {err}") from None
        self.scene = Scene(entities, contact_sensors, height_scanners, cameras)
        # world mask for solver.reset: one entry per world plus the global world (-1), which stays False
        self._world_mask = torch.zeros(num_envs + 1, dtype=torch.bool, device=self.device)
        self._world_mask_wp = wp.from_torch(self._world_mask, dtype=wp.bool)
        # forward kinematics masks articulations, not worlds: a world holds one per entity (a robot, a table, a cube)
        self._articulation_world = wp.to_torch(self.model.articulation_world).long()
        self._fk_mask = torch.zeros(self.model.articulation_count, dtype=torch.bool, device=self.device)
        self._fk_mask_wp = wp.from_torch(self._fk_mask, dtype=wp.bool)
        self._body_wrench_w = wp.to_torch(self.state.body_f).view(num_envs, -1, 6)
        self.physics_step_hooks: list[Callable[[], None]] = []
        """Work launched before every physics step after the actuators, e.g. an external wrench that follows the
        state (a harness); added with `add_physics_step_hook`. Warp launches only: the loop is graph-captured."""
        self._graphs: dict[int, object] = {}
        self._after_step_hooks: list[Callable[[], None]] = []

    def _make_terrain_collision(self, method: str, terrain_shape: int) -> None:
        contact_max = self.solver.get_max_contact_count()
        if method == "newton_pipeline":
            self.collision_pipeline = newton.CollisionPipeline(self.model, rigid_contact_max=contact_max)
            self.contacts = self.collision_pipeline.contacts()
            return
        shapes, other_pairs = split_terrain_pairs(self.model, terrain_shape)
        if len(other_pairs):  # entity-entity pairs (two robots, a hand and an object) keep Newton's pipeline
            self.collision_pipeline = newton.CollisionPipeline(
                self.model, rigid_contact_max=contact_max, broad_phase="explicit",
                shape_pairs_filtered=wp.array(other_pairs, dtype=wp.vec2i, device=self.wp_device))
            self.contacts = self.collision_pipeline.contacts()
        else:
            self.contacts = newton.Contacts(contact_max, 0, device=self.wp_device)
        try:
            self.terrain_contacts = TerrainContacts(self.model, self.terrain, terrain_shape, shapes, self.contacts)
        except ValueError as err:
            raise ConfigError(str(err)) from None

    def _make_contact_sensors(self, scene_cfg: SceneCfg, entities: dict, ground_shape: int) -> dict:
        # the solver writes each step's contact forces against the contacts it steps with: the pipeline's on a
        # terrain, else a buffer that MuJoCo's own collision detection is exported into; all sensors share them
        sensors: dict[str, ContactSensor] = {}
        if not scene_cfg.contact_sensors:
            return sensors
        self.sensor_contacts = self.contacts if self.contacts is not None else newton.Contacts(
            self.solver.get_max_contact_count(), 0, device=self.wp_device)
        self.sensor_observables = None
        for name, sensor_cfg in scene_cfg.contact_sensors.items():
            where = f"scene.contact_sensors.{name}"
            entity = entity_of(entities, sensor_cfg.entity, f"{where}.entity")
            shapes = filter_shape_ids(entities, sensor_cfg, ground_shape, where)
            try:
                sensors[name] = ContactSensor(sensor_cfg, self.model, self.solver, self.sensor_contacts, entity,
                                              shapes, self.cfg.physics_dt_s, self.sensor_observables)
            except ValueError as err:
                raise ConfigError(f"{where}: {err}") from None
            self.sensor_observables = sensors[name].solver_observables
        return sensors

    @property
    def use_graph(self) -> bool:
        if not self.cfg.use_graph:
            return False
        return self.wp_device.is_cpu or wp.is_mempool_enabled(self.wp_device)

    def _physics_loop(self, num_steps: int) -> None:
        sensors = list(self.scene.contact_sensors.values())
        for substep in range(num_steps):
            for group in self.actuator_groups:
                group.step(self.physics_dt_s, substep, num_steps)
            for hook in self.physics_step_hooks:
                hook()
            if self.collision_pipeline is not None:
                self.collision_pipeline.collide(self.state, self.contacts)
            elif self.terrain_contacts is not None:
                self.contacts.clear()
            if self.terrain_contacts is not None:
                self.terrain_contacts.collide(self.state)
            if not sensors:
                self.solver.step(self.state, self.state, self.control, self.contacts, self.physics_dt_s)
            else:
                self.solver.step(self.state, self.state, self.control, self.sensor_contacts, self.physics_dt_s,
                                 observables=self.sensor_observables)
                for sensor in sensors:
                    sensor.update(self.state)
            self.capacity.update()
        for group in self.actuator_groups:
            group.after_physics()

    def step(self, num_steps: int, graph: bool = True) -> None:
        """Advance every world by `num_steps` physics steps.

        graph=False launches the kernels one by one on the current stream: for a caller that is itself
        recording a CUDA graph (the captured env step).
        """
        if not (self.use_graph and graph):
            with wp.ScopedDevice(self.wp_device):
                self._physics_loop(num_steps)
        else:
            wp.capture_launch(self._graphs.get(num_steps) or self._capture(num_steps))
        for hook in self._after_step_hooks:
            hook()

    @contextlib.contextmanager
    def after_each_step(self, hook: Callable[[], None]):
        """Run `hook` after every `step` (the whole loop of physics steps), before anything reads the new state,
        while the context lasts: a fingerprint's replay puts a recorded state in place of the one computed
        (agile.run.fingerprint). Host code, not captured: not for a captured env step."""
        self._after_step_hooks.append(hook)
        try:
            yield
        finally:
            self._after_step_hooks.remove(hook)

    def _capture(self, num_steps: int):
        """Record the loop once. The eager warm-up (lazy allocations) and the recording must not advance the
        world, so the state and the solver's per-world buffers are put back afterwards."""
        saved = [wp.clone(a) for a in (self.state.joint_q, self.state.joint_qd, self.state.body_q, self.state.body_qd)]
        with wp.ScopedDevice(self.wp_device):
            self._physics_loop(num_steps)
            with no_collection_while_capturing(), wp.ScopedCapture(device=self.wp_device) as capture:
                self._physics_loop(num_steps)
        for dst, src in zip((self.state.joint_q, self.state.joint_qd, self.state.body_q, self.state.body_qd), saved):
            dst.assign(src)
        self.solver.reset(self.state, flags=0)  # clear warm start and applied forces, keep the joint state
        all_envs = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        for group in self.actuator_groups:
            group.reset(all_envs)
        for sensor in self.scene.contact_sensors.values():
            sensor.reset(all_envs)
        self._graphs[num_steps] = capture.graph
        return capture.graph

    def add_physics_step_hook(self, hook: Callable[[], None]) -> None:
        """Run `hook` before every physics step; physics graphs captured without it are dropped."""
        self.physics_step_hooks.append(hook)
        self._graphs.clear()

    def solver_iterations(self) -> torch.Tensor:
        """(N,) solver iterations each world took in the last physics step. On a GPU MuJoCo Warp repeats its
        iteration until the slowest world has converged (or hit the cap), so the maximum sets the step's cost;
        on the CPU every step runs the cap."""
        return wp.to_torch(self.solver.mjw_data.solver_niter)[: self.num_envs]

    def reset_worlds(self, mask: torch.Tensor) -> None:
        """Clear the solver's per-world internals (warm start, applied forces) and the contact sensors'
        histories and clocks where mask (N,) is True.

        Entity states are then written by the caller through the entities and made consistent by `forward`.
        """
        self._world_mask[: self.num_envs].copy_(mask)
        self.solver.reset(self.state, world_mask=self._world_mask_wp)
        # the solver re-applies state.body_f at every step: a disturbance must not outlive its episode
        self._body_wrench_w.masked_fill_(mask.view(-1, 1, 1), 0.0)
        for sensor in self.scene.contact_sensors.values():
            sensor.reset(mask)

    # -- terrain levels ------------------------------------------------------------------------------

    def _init_terrain_levels(self, max_init_level: int | None) -> None:
        """Env i gets column i % num_cols and a row drawn in [0, max_init_level] (Isaac Lab TerrainImporter)."""
        origins = self.terrain.cell_origins_m
        num_rows, num_cols = origins.shape[:2]
        max_init = num_rows - 1 if max_init_level is None else min(max_init_level, num_rows - 1)
        self.terrain_origins_m = torch.from_numpy(origins).to(self.device)
        """(num_rows, num_cols, 3) spawn point of each cell."""
        self.terrain_types = torch.arange(self.num_envs, device=self.device) % num_cols
        """(N,) column of each env."""
        self.terrain_levels = torch.randint(0, max_init + 1, (self.num_envs,), device=self.device)
        """(N,) row (difficulty level) of each env."""
        self.max_terrain_level = num_rows
        self.env_origins.copy_(self.terrain_origins_m[self.terrain_levels, self.terrain_types])

    def update_terrain_levels(self, move_up: torch.Tensor, move_down: torch.Tensor) -> None:
        """Move envs one row up or down where the (N,) masks say so and update `env_origins` in place.

        Envs that pass the last row restart on a random row (Isaac Lab), so solved levels keep being
        revisited; no env goes below row 0. Masked tensor math only: safe inside the captured step.
        """
        if self.terrain is None:
            raise RuntimeError("terrain levels need SimCfg.terrain (this world has a flat ground plane)")
        levels = self.terrain_levels + move_up.long() - (move_down & ~move_up).long()
        random_level = torch.randint_like(levels, self.max_terrain_level)
        levels = torch.where(levels >= self.max_terrain_level, random_level, levels.clamp(min=0))
        self.terrain_levels.copy_(levels)
        self.env_origins.copy_(self.terrain_origins_m[self.terrain_levels, self.terrain_types])

    def set_terrain_levels(self, levels: torch.Tensor) -> None:
        """Put every env on the given (N,) rows (a resumed training's) and update `env_origins` in place."""
        if self.terrain is None:
            raise RuntimeError("terrain levels need SimCfg.terrain (this world has a flat ground plane)")
        self.terrain_levels.copy_(levels.clamp(0, self.max_terrain_level - 1))
        self.env_origins.copy_(self.terrain_origins_m[self.terrain_levels, self.terrain_types])

    def same_column_envs(self, other_num_envs: int) -> torch.Tensor:
        """(N,) for each env of this world, an env of a world of `other_num_envs` envs on the same terrain column
        (env i is on column i % num_cols in both): env i takes its column's (i // num_cols)-th env there, cycling
        through them where that world has fewer. The identity for as many envs. Raises ValueError where that world
        leaves a column without an env."""
        num_cols = self.terrain_origins_m.shape[1]
        if other_num_envs < num_cols:
            raise ValueError(f"{other_num_envs} envs do not cover the terrain's {num_cols} columns")
        env_ids = torch.arange(self.num_envs, device=self.device)
        column = env_ids % num_cols
        envs_on_column = (other_num_envs - column + num_cols - 1) // num_cols  # column c: envs c, c + C, ... there
        return column + num_cols * ((env_ids // num_cols) % envs_on_column)

    def set_terrain_cells(self, levels: torch.Tensor, types: torch.Tensor, mask: torch.Tensor) -> None:
        """Put the envs of `mask` (N,) on the cells (row `levels`, column `types`, both (N,)) and update
        `env_origins` there; masked tensor math only (a reset from a state stored with its cell)."""
        if self.terrain is None:
            raise RuntimeError("terrain cells need SimCfg.terrain (this world has a flat ground plane)")
        self.terrain_levels.copy_(torch.where(mask, levels.clamp(0, self.max_terrain_level - 1), self.terrain_levels))
        self.terrain_types.copy_(torch.where(mask, types.clamp(0, self.terrain_origins_m.shape[1] - 1),
                                             self.terrain_types))
        self.env_origins.copy_(self.terrain_origins_m[self.terrain_levels, self.terrain_types])

    def physics_result(self) -> dict[str, torch.Tensor]:
        """Copies of what a physics step leaves: every world's joint coordinates "joint_q" (N, Q) and velocities
        "joint_qd" (N, D), robots' and objects' (a free body has a free joint; body poses and velocities follow from
        them), the explicit actuators' last torques, applied "joint_f" and before clipping "computed_effort" (N, D),
        and each contact sensor's readings ("contact/<sensor>/<reading>")."""
        result = {name: wp.to_torch(array).view(self.num_envs, -1).clone() for name, array in self._physics_arrays()}
        for name, sensor in self.scene.contact_sensors.items():
            result.update({f"contact/{name}/{k}": v for k, v in sensor.readings().items()})
        return result

    def write_physics_result(self, result: dict[str, torch.Tensor]) -> None:
        """Put a `physics_result()` in place of the current one and recompute the bodies' poses and velocities."""
        for name, array in self._physics_arrays():
            wp.to_torch(array).view(self.num_envs, -1).copy_(result[name])
        for name, sensor in self.scene.contact_sensors.items():
            prefix = f"contact/{name}/"
            sensor.write_readings({k[len(prefix):]: v for k, v in result.items() if k.startswith(prefix)})
        self.forward()

    def _physics_arrays(self) -> tuple[tuple[str, wp.array], ...]:
        return (("joint_q", self.state.joint_q), ("joint_qd", self.state.joint_qd),
                ("joint_f", self.control.joint_f), ("computed_effort", self.computed_effort))

    @contextlib.contextmanager
    def actuators_disabled(self):
        """Step without the explicit actuators (for measuring their cost); graphs are recaptured around it."""
        groups, self.actuator_groups = self.actuator_groups, []
        self._graphs.clear()
        try:
            yield
        finally:
            self.actuator_groups = groups
            self._graphs.clear()

    def forward(self, mask: torch.Tensor | None = None) -> None:
        """Recompute body poses from joint coordinates (forward kinematics), in the worlds of `mask`."""
        if mask is None:
            newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state)
        else:
            self._fk_mask.copy_(mask[self._articulation_world])
            newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state, mask=self._fk_mask_wp)
