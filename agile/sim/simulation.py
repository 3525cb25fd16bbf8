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
from agile.sim.names import resolve_names, resolve_values
from agile.sim.sim_cfg import RobotCfg, SimCfg

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
        scene.add_ground_plane(cfg=ground_cfg)
        self.model = scene.finalize(device=self.wp_device)
        s = cfg.solver
        self.solver = newton.solvers.SolverMuJoCo(
            self.model, iterations=s.iterations, ls_iterations=s.ls_iterations, njmax=s.njmax, nconmax=s.nconmax,
            cone=s.cone, impratio=s.impratio, integrator=s.integrator, solver=s.solver)
        # a capped iteration count is a deliberate speed/accuracy trade-off in RL: do not print a warning
        # from every world at every step when it is reached (capacity overflows still print)
        quiet = mujoco_warp.OverflowType.ITERATIONS | mujoco_warp.OverflowType.LS_ITERATIONS
        self.solver.mjw_model.opt.warn_overflow = int(self.solver.mjw_model.opt.warn_overflow) & ~int(quiet)
        self.state = self.model.state()
        self.control = self.model.control()
        self.computed_effort = wp.zeros_like(self.state.joint_qd)
        """Explicit actuators' torque before clipping, per DoF (their clipped torque is control.joint_f)."""
        self.robot = Articulation(self.model, self.state, self.control, joint_names, body_names, step_dt_s,
                                  self.computed_effort)
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
        self.env_origins = env_origins_grid(num_envs, cfg.env_spacing_m, self.device)
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
        for substep in range(num_steps):
            for group in self.actuator_groups:
                group.step(self.physics_dt_s, substep, num_steps)
            self.solver.step(self.state, self.state, self.control, None, self.physics_dt_s)
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
        for group in self.actuator_groups:
            group.reset(torch.ones(self.num_envs, dtype=torch.bool, device=self.device))
        self._graphs[num_steps] = capture.graph
        return capture.graph

    def reset_worlds(self, mask: torch.Tensor) -> None:
        """Clear the solver's per-world internals (warm start, applied forces) where mask (N,) is True.

        Joint state is then written by the caller through the Articulation and made consistent by `forward`.
        """
        self._world_mask[: self.num_envs].copy_(mask)
        self.solver.reset(self.state, world_mask=self._world_mask_wp)

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
