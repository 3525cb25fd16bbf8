"""The Newton world: N replicated robots on a ground plane, stepped by SolverMuJoCo."""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import mujoco_warp
import newton
import torch
import warp as wp

from agile.actuators import DelayedImplicitActuatorCfg, DelayedTargetGroup, ExplicitActuatorGroup, is_explicit
from agile.sim.articulation import Articulation
from agile.sim.contact_sensor import ContactSensor
from agile.sim.height_scanner import HeightScanner, TerrainHeights
from agile.sim.names import resolve_names, resolve_values
from agile.sim.sim_cfg import RobotCfg, SimCfg
from agile.sim.terrain import TerrainData, load_or_generate_terrain

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")


def short_name(label: str) -> str:
    return label.split("/")[-1]


def env_origins_grid(num_envs: int, spacing_m: float, device) -> torch.Tensor:
    """(N, 3) origins on a square grid centred on the world origin."""
    cols = math.ceil(math.sqrt(num_envs))
    idx = torch.arange(num_envs, device=device)
    origins = torch.zeros(num_envs, 3, device=device)
    origins[:, 0] = (idx // cols).float() * spacing_m
    origins[:, 1] = (idx % cols).float() * spacing_m
    origins[:, :2] -= origins[:, :2].mean(dim=0, keepdim=True)
    return origins


def build_robot(cfg: RobotCfg, gravity_mps2: float) -> tuple[newton.ModelBuilder, list[str], list[str]]:
    """One robot in its own builder, with actuator settings applied per DoF. Returns (builder, joints, bodies)."""
    path = Path(cfg.model_file)
    if not path.is_file():
        raise FileNotFoundError(f"robot model file not found: {path}")
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, gravity_mps2))
    newton.solvers.SolverMuJoCo.register_custom_attributes(builder)
    suffix = path.suffix.lower()
    if suffix == ".xml":
        builder.add_mjcf(str(path), floating=True, enable_self_collisions=cfg.self_collisions,
                         parse_visuals=cfg.parse_visuals, collider_classes=tuple(cfg.mjcf_collider_classes))
    elif suffix == ".urdf":
        builder.add_urdf(str(path), floating=True, enable_self_collisions=cfg.self_collisions)
    elif suffix in USD_SUFFIXES:
        builder.add_usd(str(path), floating=True, enable_self_collisions=cfg.self_collisions)
    else:
        raise ValueError(f"unsupported robot model file '{path}': expected .xml (MJCF), .urdf or {USD_SUFFIXES}")
    if builder.joint_count == 0 or builder.joint_type[0] != newton.JointType.FREE:
        raise ValueError(f"'{path}' did not import as one floating-base articulation")

    collide = int(newton.ShapeFlags.COLLIDE_SHAPES)
    colliders = [i for i in range(builder.shape_count) if builder.shape_flags[i] & collide]
    attrs = builder.custom_attributes
    if cfg.enable_all_colliders:
        for i in colliders:
            if builder.shape_collision_group[i] == 0:
                builder.shape_collision_group[i] = 1
            for key in ("mujoco:contype", "mujoco:conaffinity"):
                if key in attrs:
                    attrs[key].values[i] = 1
    if cfg.contact_dim is not None and "mujoco:condim" in attrs:
        for i in colliders:
            attrs["mujoco:condim"].values[i] = cfg.contact_dim

    joint_names = dof_names(builder)
    body_names = [short_name(label) for label in builder.body_label]

    # default root pose and joint positions (coordinates: 7 root + one per hinge)
    builder.joint_q[0:3] = list(cfg.init_pos_m)
    builder.joint_q[3:7] = [0.0, 0.0, 0.0, 1.0]
    for j, value in resolve_values(cfg.init_joint_pos, joint_names).items():
        builder.joint_q[7 + j] = value
        builder.joint_target_q[7 + j] = value
    for group_name, act in cfg.actuators.items():
        try:
            apply_actuator_to_builder(builder, act, joint_names)
        except ValueError as err:
            raise ValueError(f"actuator group '{group_name}': {err}") from None
    return builder, joint_names, body_names


def dof_names(builder: newton.ModelBuilder) -> list[str]:
    """One name per non-root DoF: the joint's name, or "<joint>:<k>" for a joint with several DoFs
    (Newton merges MJCF hinges on one body into one joint), as Newton's selection API names them."""
    names = []
    for j in range(1, builder.joint_count):
        name = short_name(builder.joint_label[j])
        count = sum(builder.joint_dof_dim[j])
        names.extend([name] if count == 1 else [f"{name}:{k}" for k in range(count)])
    return names


def apply_actuator_to_builder(builder: newton.ModelBuilder, act, joint_names: list[str]) -> None:
    """Write an actuator group's gains and limits into the builder's per-DoF lists (DoF 6+j is joint j)."""
    ids, names = resolve_names(act.joint_names_expr, joint_names)

    def values(value) -> dict[int, float]:
        if value is None:
            return {}
        if isinstance(value, dict):
            return {ids[k]: v for k, v in resolve_values(value, names).items()}
        return {i: float(value) for i in ids}

    # explicit actuators compute torques themselves (joint_f): the solver must not add its own PD
    mode = newton.JointTargetMode.EFFORT if is_explicit(act) else newton.JointTargetMode.POSITION
    for i in ids:
        builder.joint_target_mode[6 + i] = int(mode)
    for field_name, attr in (("stiffness", "joint_target_ke"), ("damping", "joint_target_kd"),
                             ("effort_limit", "joint_effort_limit"), ("velocity_limit", "joint_velocity_limit"),
                             ("armature", "joint_armature"), ("friction", "joint_friction")):
        for i, v in values(getattr(act, field_name)).items():
            getattr(builder, attr)[6 + i] = v


def terrain_heightfield(terrain: TerrainData) -> newton.Heightfield:
    """The terrain as a Newton height field centred on the world origin (rows of `data` run along y)."""
    nx, ny = terrain.heights_m.shape
    h = terrain.horizontal_scale_m
    return newton.Heightfield(data=terrain.heights_m.T, nrow=ny, ncol=nx, hx=(nx - 1) * h / 2, hy=(ny - 1) * h / 2)


class Simulation:
    """Builds the replicated world and steps it; the decimation loop is one captured graph."""

    def __init__(self, cfg: SimCfg, robot_cfg: RobotCfg, num_envs: int, device: str, step_dt_s: float):
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.cfg = cfg
        self.num_envs = num_envs
        self.wp_device = wp.get_device(device)
        self.device = torch.device(wp.device_to_torch(self.wp_device))
        self.physics_dt_s = cfg.physics_dt_s
        if self.wp_device.is_cuda:
            # one CUDA stream for Warp and torch: term math and physics stay ordered without host syncs,
            # and graph capture runs on a non-default stream
            torch.cuda.set_stream(wp.stream_to_torch(wp.get_stream(self.wp_device)))

        robot_builder, joint_names, body_names = build_robot(robot_cfg, cfg.gravity_mps2)
        scene = newton.ModelBuilder(gravity=(0.0, 0.0, cfg.gravity_mps2))
        newton.solvers.SolverMuJoCo.register_custom_attributes(scene)
        scene.replicate(robot_builder, copy_count=num_envs, spacing=(0.0, 0.0, 0.0))
        ground_cfg = newton.ModelBuilder.ShapeConfig(mu=cfg.ground_friction)
        self.terrain: TerrainData | None = None
        if cfg.terrain is None:
            scene.add_ground_plane(cfg=ground_cfg)
        else:
            self.terrain = load_or_generate_terrain(cfg.terrain)
            scene.add_shape_heightfield(heightfield=terrain_heightfield(self.terrain), cfg=ground_cfg, label="terrain")
        self.model = scene.finalize(device=self.wp_device)
        if self.terrain is not None:
            self.model.shape_gap.fill_(cfg.terrain_contact_gap_m)
        s = cfg.solver
        self.solver = newton.solvers.SolverMuJoCo(
            self.model, iterations=s.iterations, ls_iterations=s.ls_iterations, njmax=s.njmax, nconmax=s.nconmax,
            cone=s.cone, impratio=s.impratio, integrator=s.integrator, solver=s.solver,
            use_mujoco_contacts=self.terrain is None)
        # on a terrain Newton detects the contacts: mujoco_warp's height-field collision throws boxes (feet)
        # off the field (seen on CPU, mujoco_warp 3.17), Newton's pipeline rests them at the right height
        self.collision_pipeline: newton.CollisionPipeline | None = None
        self.contacts: newton.Contacts | None = None
        if self.terrain is not None:
            self.collision_pipeline = newton.CollisionPipeline(
                self.model, rigid_contact_max=self.solver.get_max_contact_count())
            self.contacts = self.collision_pipeline.contacts()
        # a capped iteration count is a deliberate speed/accuracy trade-off in RL: do not print a warning
        # from every world at every step when it is reached (capacity overflows still print)
        quiet = mujoco_warp.OverflowType.ITERATIONS | mujoco_warp.OverflowType.LS_ITERATIONS
        self.solver.mjw_model.opt.warn_overflow = int(self.solver.mjw_model.opt.warn_overflow) & ~int(quiet)
        self.state = self.model.state()
        self.control = self.model.control()
        self.computed_effort = wp.zeros_like(self.state.joint_qd)
        """Explicit actuators' torque before clipping, per DoF (their clipped torque is control.joint_f)."""
        self.robot = Articulation(self.model, self.state, self.control, joint_names, body_names, step_dt_s,
                                  self.computed_effort, robot_cfg.soft_joint_pos_limit_factor)
        self.actuator_groups: list[ExplicitActuatorGroup | DelayedTargetGroup] = []
        """Per-physics-step actuator work: explicit torque models and delayed implicit targets."""
        for name, act in robot_cfg.actuators.items():
            if isinstance(act, DelayedImplicitActuatorCfg):
                ids, _ = self.robot.find_joints(act.joint_names_expr)
                self.actuator_groups.append(DelayedTargetGroup(name, act, ids, self.control, num_envs, self.device))
                continue
            if not is_explicit(act):
                continue
            ids, _ = self.robot.find_joints(act.joint_names_expr)
            values = {"stiffness": self.robot.joint_stiffness[0, ids], "damping": self.robot.joint_damping[0, ids],
                      "effort_limit": self.robot.joint_effort_limit[0, ids],
                      "velocity_limit": self.robot.joint_vel_limit[0, ids]}
            if getattr(act, "saturation_effort", None) is not None:
                values["saturation_effort"] = torch.tensor(
                    [v for _, v in sorted(resolve_values(act.saturation_effort,
                                                         [joint_names[i] for i in ids]).items())])
            elif hasattr(act, "saturation_effort"):
                raise ValueError(f"actuator group '{name}': a DC motor needs saturation_effort")
            self.actuator_groups.append(ExplicitActuatorGroup(
                name, act, ids, values, self.state, self.control, self.computed_effort, num_envs, self.device))
        self.robot.set_explicit_joints([i for g in self.actuator_groups if isinstance(g, ExplicitActuatorGroup)
                                        for i in g.joint_id_list])
        self.contact_sensor: ContactSensor | None = None
        if cfg.contact_sensor is not None:
            # the solver writes each step's contact forces against the contacts it steps with: the pipeline's on a
            # terrain, else a buffer that MuJoCo's own collision detection is exported into
            contacts = self.contacts if self.contacts is not None else newton.Contacts(
                self.solver.get_max_contact_count(), 0, device=self.wp_device)
            try:
                self.contact_sensor = ContactSensor(cfg.contact_sensor, self.model, self.solver, contacts,
                                                    body_names, cfg.physics_dt_s)
            except ValueError as err:
                raise ValueError(f"contact sensor: {err}") from None
        self.env_origins = env_origins_grid(num_envs, cfg.env_spacing_m, self.device)
        """(N, 3) spawn point of each env; changed in place when an env changes terrain level."""
        if self.terrain is not None:
            self._init_terrain_levels(cfg.max_init_terrain_level)
        terrain_heights = None if self.terrain is None else TerrainHeights(
            torch.from_numpy(self.terrain.heights_m).to(self.device), self.terrain.origin_xy_m,
            self.terrain.horizontal_scale_m)
        self.height_scanners: dict[str, HeightScanner] = {}
        for name, scanner_cfg in cfg.height_scanners.items():
            try:
                self.height_scanners[name] = HeightScanner(scanner_cfg, self.robot, terrain_heights)
            except ValueError as err:
                raise ValueError(f"height scanner '{name}': {err}") from None
        # world mask for solver.reset: one entry per world plus the global world (-1), which stays False
        self._world_mask = torch.zeros(num_envs + 1, dtype=torch.bool, device=self.device)
        self._world_mask_wp = wp.from_torch(self._world_mask, dtype=wp.bool)
        self._fk_mask_wp = wp.from_torch(self._world_mask[:num_envs], dtype=wp.bool)
        self._graphs: dict[int, object] = {}

    @property
    def use_graph(self) -> bool:
        if not self.cfg.use_graph:
            return False
        return self.wp_device.is_cpu or wp.is_mempool_enabled(self.wp_device)

    def _physics_loop(self, num_steps: int) -> None:
        sensor = self.contact_sensor
        for substep in range(num_steps):
            for group in self.actuator_groups:
                group.step(self.physics_dt_s, substep, num_steps)
            if self.collision_pipeline is not None:
                self.collision_pipeline.collide(self.state, self.contacts)
            if sensor is None:
                self.solver.step(self.state, self.state, self.control, self.contacts, self.physics_dt_s)
            else:
                self.solver.step(self.state, self.state, self.control, sensor.contacts, self.physics_dt_s,
                                 observables=sensor.solver_observables)
                sensor.update(self.state)
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
            return
        graph = self._graphs.get(num_steps) or self._capture(num_steps)
        wp.capture_launch(graph)

    def _capture(self, num_steps: int):
        """Record the loop once. The eager warm-up (lazy allocations) and the recording must not advance the
        world, so the state and the solver's per-world buffers are put back afterwards."""
        saved = [wp.clone(a) for a in (self.state.joint_q, self.state.joint_qd, self.state.body_q, self.state.body_qd)]
        with wp.ScopedDevice(self.wp_device):
            self._physics_loop(num_steps)
            with wp.ScopedCapture(device=self.wp_device) as capture:
                self._physics_loop(num_steps)
        for dst, src in zip((self.state.joint_q, self.state.joint_qd, self.state.body_q, self.state.body_qd), saved):
            dst.assign(src)
        self.solver.reset(self.state, flags=0)  # clear warm start and applied forces, keep the joint state
        all_envs = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        for group in self.actuator_groups:
            group.reset(all_envs)
        if self.contact_sensor is not None:
            self.contact_sensor.reset(all_envs)
        self._graphs[num_steps] = capture.graph
        return capture.graph

    def solver_iterations(self) -> torch.Tensor:
        """(N,) solver iterations each world took in the last physics step. On a GPU MuJoCo Warp repeats its
        iteration until the slowest world has converged (or hit the cap), so the maximum sets the step's cost;
        on the CPU every step runs the cap."""
        return wp.to_torch(self.solver.mjw_data.solver_niter)[: self.num_envs]

    def reset_worlds(self, mask: torch.Tensor) -> None:
        """Clear the solver's per-world internals (warm start, applied forces) and the contact sensor's
        histories and clocks where mask (N,) is True.

        Joint state is then written by the caller through the Articulation and made consistent by `forward`.
        """
        self._world_mask[: self.num_envs].copy_(mask)
        self.solver.reset(self.state, world_mask=self._world_mask_wp)
        # the solver re-applies state.body_f at every step: a disturbance must not outlive its episode
        self.robot.body_wrench_w.masked_fill_(mask.view(-1, 1, 1), 0.0)
        if self.contact_sensor is not None:
            self.contact_sensor.reset(mask)

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

    def reset_actuators(self, mask: torch.Tensor) -> None:
        """Clear actuator state (delay buffers) and draw new per-env delays where mask (N,) is True."""
        for group in self.actuator_groups:
            group.reset(mask)

    def forward(self, mask: torch.Tensor | None = None) -> None:
        """Recompute body poses from joint coordinates (forward kinematics), in the worlds of `mask`."""
        if mask is None:
            newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state)
        else:
            self._world_mask[: self.num_envs].copy_(mask)
            newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state, mask=self._fk_mask_wp)
