"""One entity in its own Newton builder: an articulation from a model file, or a rigid object from a shape.

The scene adds these builders one after another into the template of a world, which is then replicated
into every world.
"""

from __future__ import annotations

from pathlib import Path

import newton
import numpy as np
import warp as wp

from agile.actuators import is_explicit
from agile.actuators.implicit import check_actuator_values
from agile.sim.names import resolve_names, resolve_values
from agile.sim.scene_cfg import (BODY_TYPES, ArticulationCfg, BoxShapeCfg, CapsuleShapeCfg, CylinderShapeCfg,
                                 MeshFileShapeCfg, ModelFileShapeCfg, RigidObjectCfg, SphereShapeCfg)

USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")


def short_name(label: str) -> str:
    return label.split("/")[-1]


def new_builder(gravity_mps2: float) -> newton.ModelBuilder:
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, gravity_mps2))
    newton.solvers.SolverMuJoCo.register_custom_attributes(builder)
    return builder


def import_model_file(builder: newton.ModelBuilder, path: Path, floating: bool, self_collisions: bool = False,
                      parse_visuals: bool = False, collider_classes: tuple[str, ...] = ("collision",)) -> None:
    """Add an MJCF, URDF or USD file to `builder` through Newton's importers."""
    if not path.is_file():
        raise FileNotFoundError(f"model file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".xml":
        builder.add_mjcf(str(path), floating=floating, enable_self_collisions=self_collisions,
                         parse_visuals=parse_visuals, collider_classes=tuple(collider_classes))
    elif suffix == ".urdf":
        builder.add_urdf(str(path), floating=floating, enable_self_collisions=self_collisions)
    elif suffix in USD_SUFFIXES:
        builder.add_usd(str(path), floating=floating, enable_self_collisions=self_collisions)
    else:
        raise ValueError(f"unsupported model file '{path}': expected .xml (MJCF), .urdf or {USD_SUFFIXES}")


def dof_names(builder: newton.ModelBuilder) -> list[str]:
    """One name per non-root DoF: the joint's name, or "<joint>:<k>" for a joint with several DoFs
    (Newton merges MJCF hinges on one body into one joint), as Newton's selection API names them."""
    names = []
    for j in range(1, builder.joint_count):
        name = short_name(builder.joint_label[j])
        count = sum(builder.joint_dof_dim[j])
        names.extend([name] if count == 1 else [f"{name}:{k}" for k in range(count)])
    return names


CONTACT_DIMS = (1, 3, 4, 6)
"""MuJoCo's condim values: frictionless, friction cone, with torsional, with rolling friction."""


def check_pose_and_contacts(cfg: ArticulationCfg | RigidObjectCfg) -> None:
    """Raise ValueError naming the field: the initial orientation must be a unit quaternion (a zero one would
    reach the solver as a degenerate rotation), the contact dimension one MuJoCo knows."""
    norm = float(np.linalg.norm(cfg.init_rot_xyzw))
    if len(cfg.init_rot_xyzw) != 4 or abs(norm - 1.0) > 1e-3:
        raise ValueError(f"init_rot_xyzw must be a unit quaternion (x, y, z, w), got {tuple(cfg.init_rot_xyzw)}")
    if cfg.contact_dim is not None and cfg.contact_dim not in CONTACT_DIMS:
        raise ValueError(f"contact_dim must be one of {CONTACT_DIMS} (MuJoCo condim), got {cfg.contact_dim}")


def build_articulation(cfg: ArticulationCfg, gravity_mps2: float) -> tuple[newton.ModelBuilder, list[str], list[str]]:
    """One articulation in its own builder, with actuator settings applied per DoF. Returns (builder, joints,
    bodies)."""
    check_pose_and_contacts(cfg)
    builder = new_builder(gravity_mps2)
    import_model_file(builder, Path(cfg.model_file), floating=not cfg.fixed_base,
                      self_collisions=cfg.self_collisions, parse_visuals=cfg.parse_visuals,
                      collider_classes=cfg.mjcf_collider_classes)
    if builder.articulation_count != 1:
        raise ValueError(f"'{cfg.model_file}' imported as {builder.articulation_count} articulations, expected one")
    root_type = builder.joint_type[0] if builder.joint_count else None
    expected = newton.JointType.FIXED if cfg.fixed_base else newton.JointType.FREE
    if root_type != expected:
        raise ValueError(f"'{cfg.model_file}' did not import with a {expected.name} root joint "
                         f"(fixed_base={cfg.fixed_base}); its root joint is {root_type}")

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
    if cfg.collider_margin_m is not None:
        if cfg.collider_margin_m < 0.0:
            raise ValueError(f"collider_margin_m must be >= 0 (or None for the file's), got {cfg.collider_margin_m}")
        for i in colliders:
            builder.shape_margin[i] = cfg.collider_margin_m

    joint_names = dof_names(builder)
    body_names = [short_name(label) for label in builder.body_label]
    root_xform = wp.transform(cfg.init_pos_m, cfg.init_rot_xyzw)
    # a free root's pose is its joint coordinates; a fixed root's is the joint's frame in the world
    if cfg.fixed_base:
        builder.joint_X_p[0] = root_xform
    else:
        builder.joint_q[0:7] = [*cfg.init_pos_m, *cfg.init_rot_xyzw]
    root_coords = 0 if cfg.fixed_base else 7
    for j, value in resolve_values(cfg.init_joint_pos, joint_names).items():
        builder.joint_q[root_coords + j] = value
        builder.joint_target_q[root_coords + j] = value
    root_dofs = 0 if cfg.fixed_base else 6
    for group_name, act in cfg.actuators.items():
        try:
            apply_actuator_to_builder(builder, act, joint_names, root_dofs)
        except ValueError as err:
            raise ValueError(f"actuator group '{group_name}': {err}") from None
    return builder, joint_names, body_names


def apply_actuator_to_builder(builder: newton.ModelBuilder, act, joint_names: list[str], root_dofs: int) -> None:
    """Write an actuator group's gains and limits into the builder's per-DoF lists (DoF root_dofs+j is joint j)."""
    check_actuator_values(act)
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
        builder.joint_target_mode[root_dofs + i] = int(mode)
    for field_name, attr in (("stiffness", "joint_target_ke"), ("damping", "joint_target_kd"),
                             ("effort_limit", "joint_effort_limit"), ("velocity_limit", "joint_velocity_limit"),
                             ("armature", "joint_armature"), ("friction", "joint_friction")):
        for i, v in values(getattr(act, field_name)).items():
            getattr(builder, attr)[root_dofs + i] = v


def build_rigid_object(cfg: RigidObjectCfg, name: str, gravity_mps2: float) -> tuple[newton.ModelBuilder, list[str]]:
    """One rigid body in its own builder, as an articulation of one joint (free, or fixed to the world) so that
    every world can place it at its own env origin. Returns (builder, body names)."""
    if cfg.body_type not in BODY_TYPES:
        raise ValueError(f"body_type '{cfg.body_type}' is not one of {list(BODY_TYPES)}")
    check_pose_and_contacts(cfg)
    kinematic = cfg.body_type == "kinematic"
    if kinematic and cfg.mass_kg is not None:
        raise ValueError("mass_kg: a kinematic object has no mass (it moves only where its root state is written); "
                         "leave mass_kg None or make it dynamic")
    builder = new_builder(gravity_mps2)
    xform = wp.transform(cfg.init_pos_m, cfg.init_rot_xyzw)
    # a kinematic body has no mass: Newton's MuJoCo solver then drives it as a mocap body from its coordinates
    density = 0.0 if kinematic else cfg.density_kg_m3
    shape_cfg = newton.ModelBuilder.ShapeConfig(density=density, mu=cfg.friction, restitution=cfg.restitution)
    shape = cfg.shape
    if isinstance(shape, ModelFileShapeCfg):
        import_model_file(builder, Path(shape.path), floating=cfg.body_type != "fixed")
        if builder.body_count != 1:
            raise ValueError(f"shape.path '{shape.path}' holds {builder.body_count} bodies; a rigid object has one")
        body = 0
        if cfg.body_type == "fixed":
            builder.joint_X_p[0] = xform
        else:
            builder.joint_q[0:7] = [*cfg.init_pos_m, *cfg.init_rot_xyzw]
        if kinematic:
            builder.body_flags[body] = int(newton.BodyFlags.KINEMATIC)
            builder.body_mass[body], builder.body_inv_mass[body] = 0.0, 0.0
            builder.body_inertia[body] = wp.mat33(0.0)
            builder.body_inv_inertia[body] = wp.mat33(0.0)
    else:
        if cfg.body_type == "fixed":
            body = builder.add_link(xform=xform, label=name)
            joint = builder.add_joint_fixed(parent=-1, child=body, parent_xform=xform, label=f"{name}_fixed_joint")
            builder.add_articulation([joint], label=name)
        else:
            body = builder.add_body(xform=xform, is_kinematic=kinematic, label=name)
        add_shape(builder, body, shape, shape_cfg, cfg.color_rgb)
    if cfg.mass_kg is not None:
        if cfg.mass_kg <= 0.0:
            raise ValueError(f"mass_kg must be > 0 (or None for the density's), got {cfg.mass_kg}")
        scale = cfg.mass_kg / builder.body_mass[body]
        builder.body_mass[body] = cfg.mass_kg
        builder.body_inv_mass[body] = 1.0 / cfg.mass_kg
        builder.body_inertia[body] = builder.body_inertia[body] * scale
        builder.body_inv_inertia[body] = wp.inverse(builder.body_inertia[body])
    for i in range(builder.shape_count):
        if "mujoco:condim" in builder.custom_attributes:
            builder.custom_attributes["mujoco:condim"].values[i] = cfg.contact_dim
    return builder, [short_name(label) for label in builder.body_label]


def add_shape(builder: newton.ModelBuilder, body: int, shape, shape_cfg: newton.ModelBuilder.ShapeConfig,
              color_rgb: tuple[float, float, float] | None = None) -> None:
    """The collision shape of a rigid object, centred on its body frame, in `color_rgb` (None: Newton's palette)."""
    color = None if color_rgb is None else tuple(float(c) for c in color_rgb)
    if isinstance(shape, BoxShapeCfg):
        hx, hy, hz = (0.5 * s for s in shape.size_m)
        builder.add_shape_box(body, hx=hx, hy=hy, hz=hz, cfg=shape_cfg, color=color)
    elif isinstance(shape, SphereShapeCfg):
        builder.add_shape_sphere(body, radius=shape.radius_m, cfg=shape_cfg, color=color)
    elif isinstance(shape, CapsuleShapeCfg):
        builder.add_shape_capsule(body, radius=shape.radius_m, half_height=shape.half_height_m, cfg=shape_cfg,
                                  color=color)
    elif isinstance(shape, CylinderShapeCfg):
        builder.add_shape_cylinder(body, radius=shape.radius_m, half_height=shape.half_height_m, cfg=shape_cfg,
                                   color=color)
    elif isinstance(shape, MeshFileShapeCfg):
        builder.add_shape_mesh(body, mesh=load_mesh(shape), cfg=shape_cfg, color=color)
    else:
        raise ValueError(f"unknown shape config {type(shape).__name__}")


def load_mesh(shape: MeshFileShapeCfg) -> newton.Mesh:
    import trimesh

    path = Path(shape.path)
    if not path.is_file():
        raise FileNotFoundError(f"shape.path: mesh file not found: {path}")
    try:
        mesh = trimesh.load(str(path), force="mesh")
    except Exception as err:  # trimesh raises many types for a file it cannot read
        raise ValueError(f"shape.path: trimesh could not load '{path}': {err}") from None
    if len(mesh.faces) == 0:
        raise ValueError(f"shape.path: '{path}' has no triangles")
    vertices = np.asarray(mesh.vertices, dtype=np.float32) * np.asarray(shape.scale, dtype=np.float32)
    return newton.Mesh(vertices, np.asarray(mesh.faces, dtype=np.int32).flatten())
