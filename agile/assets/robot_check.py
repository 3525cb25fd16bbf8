"""What a task author needs to know of a robot's model file before writing its definition, and what in it breaks
training: `check_robot` imports the file through Newton's importers (as agile's scene does) and reports its joints,
bodies, actuators, the default pose's base height and the feet candidates, with a list of problems.

    agile robot check path/to/robot.xml --joint_pos '.*_thigh_joint=0.9' '.*_calf_joint=-1.8'
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from pathlib import Path

from agile.errors import AgileError

MJCF_SUFFIXES = (".xml",)
URDF_SUFFIXES = (".urdf",)
USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
UNLIMITED = 1.0e9
"""Newton stores a joint range it was not given as ±1e10 and an effort limit it was not given as 1e6: values at or
beyond these bounds are read as absent."""
NO_EFFORT_LIMIT_NM = 1.0e6
FEET_TOLERANCE_M = 0.02
"""A body is a feet candidate when one of its colliders reaches within this of the lowest point at the default pose."""
MIN_INERTIA_KGM2 = 1.0e-12


class RobotCheckError(AgileError, ValueError):
    """A model file that cannot be checked: missing, of an unknown format, or refused by the importer."""


@dataclasses.dataclass(frozen=True)
class JointInfo:
    name: str
    lower_rad: float | None
    """None: no lower limit (also for the upper one)."""
    upper_rad: float | None
    armature_kgm2: float
    effort_limit_nm: float | None
    velocity_limit_radps: float | None
    default_pos_rad: float


@dataclasses.dataclass(frozen=True)
class BodyInfo:
    name: str
    mass_kg: float
    principal_inertia_kgm2: tuple[float, float, float]
    lowest_point_m: float | None
    """The lowest point of its colliders at the default pose, root at the origin; None: no collider."""


@dataclasses.dataclass(frozen=True)
class ActuatorInfo:
    name: str
    joint: str
    effort_limit_nm: float | None


@dataclasses.dataclass(frozen=True)
class Problem:
    subject: str
    """What it is about, e.g. "joint FR_hip_joint", "body trunk", "actuator FR_calf"."""
    what: str

    def __str__(self) -> str:
        return f"{self.subject}: {self.what}"


@dataclasses.dataclass(frozen=True)
class RobotReport:
    model_file: str
    root_body: str
    floating_base: bool
    joints: list[JointInfo]
    bodies: list[BodyInfo]
    actuators: list[ActuatorInfo]
    default_base_height_m: float | None
    """The root's height above flat ground with the lowest collider touching it at the default pose."""
    feet_candidates: list[str]
    self_collisions: list[tuple[str, str]] | None
    """Body pairs whose colliders overlap at the default pose; None: not checked (see notes)."""
    problems: list[Problem]
    notes: list[str]


def check_robot(*, model_file: str | Path, joint_pos: dict[str, float] | None = None,
                collider_classes: tuple[str, ...] = ("collision",)) -> RobotReport:
    """The report of `model_file` (MJCF .xml, URDF or USD) at the default pose: every joint at `joint_pos`
    ({joint-name regex: rad}, as an `ArticulationCfg.init_joint_pos`), the others at 0, each clamped into its range.
    `collider_classes`: the MJCF classes whose geoms collide (`ArticulationCfg.mjcf_collider_classes`).
    Raises RobotCheckError for a file that cannot be read."""
    import newton
    import numpy as np

    path = Path(model_file)
    builder = import_model(path, collider_classes)
    notes: list[str] = []
    _dropped_colliders(builder, path, collider_classes, notes)
    problems: list[Problem] = []
    labels = [label.split("/")[-1] for label in builder.joint_label]
    body_names = [label.split("/")[-1] for label in builder.body_label]
    root_joint = newton.JointType(builder.joint_type[0]) if builder.joint_count else None
    floating = root_joint == newton.JointType.FREE
    root_body = body_names[builder.joint_child[0]] if builder.joint_count else (body_names or ["?"])[0]
    if path.suffix.lower() in URDF_SUFFIXES:
        notes.append("a URDF has no free joint: agile imports it with a free root (ArticulationCfg.fixed_base False)")
    elif not floating:
        problems.append(Problem(f"body {root_body}", f"no floating base: the root is attached to the world by a "
                                f"{'no' if root_joint is None else root_joint.name} joint; a walking robot needs a "
                                f"free root (MJCF: <freejoint/> in the root body)"))

    dof_joint = _dof_joint_names(builder, labels)
    joints = _joints(builder, dof_joint, joint_pos or {}, notes, problems)
    _pose(builder, joints, dof_joint, floating)
    with warnings.catch_warnings():  # finalize corrects a bad inertia with a warning: reported as a problem below
        warnings.simplefilter("ignore")
        model = builder.finalize(device="cpu")
    state = model.state()
    newton.eval_fk(model, model.joint_q, model.joint_qd, state)
    body_q = state.body_q.numpy()
    lowest = _lowest_points(builder, body_q, np)

    bodies = []
    for b, name in enumerate(body_names):
        mass = float(builder.body_mass[b])
        inertia = np.asarray(builder.body_inertia[b], dtype=float).reshape(3, 3)
        principal = tuple(float(v) for v in np.linalg.eigvalsh(0.5 * (inertia + inertia.T)))
        bodies.append(BodyInfo(name, mass, principal, lowest.get(b)))
        if not mass > 0.0:
            problems.append(Problem(f"body {name}", f"mass {mass:g} kg: a moving body needs a positive mass"))
        if not min(principal) > MIN_INERTIA_KGM2:
            problems.append(Problem(f"body {name}", "inertia not positive definite (principal moments "
                                    f"{', '.join(f'{v:.3g}' for v in principal)} kg·m²)"))

    actuators = _actuators(builder, path, dof_joint, notes)
    for act in actuators:
        if act.effort_limit_nm is None:
            problems.append(Problem(f"actuator {act.name}", f"no effort limit on joint {act.joint}: the policy can "
                                    "ask for any torque (MJCF: forcerange on the actuator or actuatorfrcrange on "
                                    "the joint; URDF: <limit effort=...>)"))

    height, feet = None, []
    if lowest:
        floor = min(lowest.values())
        height = float(body_q[builder.joint_child[0]][2] - floor) if builder.joint_count else None
        feet = [body_names[b] for b, z in sorted(lowest.items()) if z <= floor + FEET_TOLERANCE_M]
    else:
        problems.append(Problem(f"body {root_body}", "the model has no collider: it falls through the ground"))

    self_collisions = _self_collisions(path, joints, notes)
    for a, b in self_collisions or []:
        problems.append(Problem(f"bodies {a} and {b}", "their colliders overlap at the default pose "
                                "(self-collision: the solver pushes them apart at the first step)"))
    return RobotReport(model_file=str(path), root_body=root_body, floating_base=floating, joints=joints,
                       bodies=bodies, actuators=actuators, default_base_height_m=height, feet_candidates=feet,
                       self_collisions=self_collisions, problems=problems, notes=notes)


def import_model(path: Path, collider_classes: tuple[str, ...] = ("collision",)):
    """A Newton builder holding the file as its importer reads it (MuJoCo's attributes registered, as in a scene)."""
    import newton

    if not path.is_file():
        raise RobotCheckError(f"model file not found: {path}")
    suffix = path.suffix.lower()
    if suffix not in (*MJCF_SUFFIXES, *URDF_SUFFIXES, *USD_SUFFIXES):
        raise RobotCheckError(f"unsupported model file '{path}': expected .xml (MJCF), .urdf or {USD_SUFFIXES}")
    builder = newton.ModelBuilder()
    newton.solvers.SolverMuJoCo.register_custom_attributes(builder)
    try:
        if suffix in MJCF_SUFFIXES:
            builder.add_mjcf(str(path), parse_visuals=False, collider_classes=tuple(collider_classes))
        elif suffix in URDF_SUFFIXES:
            builder.add_urdf(str(path), floating=True)
        else:
            builder.add_usd(str(path))
    except Exception as err:  # the importers raise many kinds for a file they cannot parse
        raise RobotCheckError(f"Newton could not import '{path}': {type(err).__name__}: {err}") from None
    if builder.body_count == 0:
        raise RobotCheckError(f"'{path}' holds no body")
    return builder


def _dropped_colliders(builder, path: Path, collider_classes: tuple[str, ...], notes: list[str]) -> None:
    """A note when Newton imported fewer colliders than the MJCF has geoms outside its visual class: their classes
    are missing from `collider_classes` (Newton matches a geom's class by name, not its parents')."""
    import mujoco
    import newton

    if path.suffix.lower() not in MJCF_SUFFIXES:
        return
    try:
        spec = mujoco.MjSpec.from_file(str(path))  # held while its geoms are read: they point into it
        geoms = [g.classname.name for g in spec.geoms]
    except Exception:  # a file MuJoCo refuses is reported by the self-collision check
        return
    solid = [name for name in geoms if name != "visual"]
    collide = int(newton.ShapeFlags.COLLIDE_SHAPES)
    imported = sum(1 for s in range(builder.shape_count) if builder.shape_flags[s] & collide)
    if imported < len(solid):
        classes = sorted({name for name in solid if name not in collider_classes})
        notes.append(f"Newton imported {imported} of the {len(solid)} geoms outside the visual class as colliders: "
                     f"geoms of the classes {', '.join(classes)} may be dropped (--collider_classes, "
                     "ArticulationCfg.mjcf_collider_classes)")


def _dof_joint_names(builder, labels: list[str]) -> dict[int, str]:
    """{DoF index: its name} of every non-root joint ("<joint>:<k>" for a joint of several DoFs, as the scene names
    them)."""
    names = {}
    for j in range(1, builder.joint_count):
        start, count = builder.joint_qd_start[j], sum(builder.joint_dof_dim[j])
        for k in range(count):
            names[start + k] = labels[j] if count == 1 else f"{labels[j]}:{k}"
    return names


def _bound(value: float) -> float | None:
    return None if abs(value) >= UNLIMITED else float(value)


def _joints(builder, dof_joint: dict[int, str], joint_pos: dict[str, float], notes: list[str],
            problems: list[Problem]) -> list[JointInfo]:
    joints = []
    unmatched = {expr for expr in joint_pos}
    for dof, name in dof_joint.items():
        lower, upper = _bound(builder.joint_limit_lower[dof]), _bound(builder.joint_limit_upper[dof])
        value = 0.0
        for expr, v in joint_pos.items():
            if re.fullmatch(expr, name):
                value = float(v)
                unmatched.discard(expr)
        clamped = min(max(value, lower if lower is not None else -math.inf), upper if upper is not None else math.inf)
        if clamped != value:
            notes.append(f"joint {name}: default {value:g} rad is outside its range [{lower:g}, {upper:g}], "
                         f"taken as {clamped:g} (name it in init_joint_pos)")
        if lower is None or upper is None:
            problems.append(Problem(f"joint {name}", "no position limits: the policy can wind it up without bound "
                                    "(MJCF: range=...; URDF: <limit lower upper>)"))
        effort = builder.joint_effort_limit[dof]
        joints.append(JointInfo(name, lower, upper, float(builder.joint_armature[dof]),
                                None if effort >= NO_EFFORT_LIMIT_NM else float(effort),
                                None if builder.joint_velocity_limit[dof] >= NO_EFFORT_LIMIT_NM
                                else float(builder.joint_velocity_limit[dof]), clamped))
    if unmatched:
        raise RobotCheckError(f"--joint_pos {', '.join(sorted(unmatched))} matches no joint; the joints: "
                              f"{', '.join(dof_joint.values())}")
    return joints


def _pose(builder, joints: list[JointInfo], dof_joint: dict[int, str], floating: bool) -> None:
    """Write the default pose into the builder's coordinates, the root at the origin, upright; a joint of several
    DoFs (ball, D6) keeps the file's coordinates."""
    import newton

    if floating:
        builder.joint_q[0:7] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    by_name = {j.name: j.default_pos_rad for j in joints}
    single = (newton.JointType.REVOLUTE, newton.JointType.PRISMATIC)
    for j in range(1, builder.joint_count):
        if builder.joint_type[j] in single:
            builder.joint_q[builder.joint_q_start[j]] = by_name[dof_joint[builder.joint_qd_start[j]]]


def _lowest_points(builder, body_q, np) -> dict[int, float]:
    """{body: the lowest world z of its colliders} at the pose in `body_q` (Newton's shapes: spheres, capsules and
    cylinders along their z axis, boxes, meshes)."""
    import newton
    import warp as wp

    collide = int(newton.ShapeFlags.COLLIDE_SHAPES)
    lowest: dict[int, float] = {}
    for s in range(builder.shape_count):
        body = builder.shape_body[s]
        if body < 0 or not builder.shape_flags[s] & collide:
            continue
        pose = wp.transform(wp.vec3(*body_q[body][:3].tolist()), wp.quat(*body_q[body][3:].tolist()))
        world = wp.transform_multiply(pose, builder.shape_transform[s])
        centre = np.array(wp.transform_get_translation(world), dtype=float)
        rot = np.array(wp.quat_to_matrix(wp.transform_get_rotation(world)), dtype=float).reshape(3, 3)
        scale = np.array(builder.shape_scale[s], dtype=float)
        kind = builder.shape_type[s]
        axis_z = rot[2, 2]  # the z component of the shape's own z axis
        if kind == newton.GeoType.SPHERE:
            z = centre[2] - scale[0]
        elif kind == newton.GeoType.CAPSULE:
            z = centre[2] - abs(axis_z) * scale[1] - scale[0]
        elif kind == newton.GeoType.CYLINDER:
            z = centre[2] - abs(axis_z) * scale[1] - scale[0] * math.sqrt(max(0.0, 1.0 - axis_z ** 2))
        elif kind == newton.GeoType.BOX:
            z = centre[2] - float(np.abs(rot[2]) @ scale)
        elif kind in (newton.GeoType.MESH, newton.GeoType.CONVEX_MESH) and builder.shape_source[s] is not None:
            vertices = np.asarray(builder.shape_source[s].vertices, dtype=float) * scale
            z = centre[2] + float((vertices @ rot.T)[:, 2].min())
        else:
            continue
        lowest[body] = min(lowest.get(body, math.inf), float(z))
    return lowest


def _actuators(builder, path: Path, dof_joint: dict[int, str], notes: list[str]) -> list[ActuatorInfo]:
    """The file's actuators with their effort limits: an MJCF's <actuator> elements on joints (forcerange, else the
    joint's actuatorfrcrange); a URDF's or USD's driven joints (their effort limit)."""
    attrs = builder.custom_attributes
    if path.suffix.lower() not in MJCF_SUFFIXES:
        return [ActuatorInfo(name, name, None if builder.joint_effort_limit[dof] >= NO_EFFORT_LIMIT_NM
                             else float(builder.joint_effort_limit[dof])) for dof, name in dof_joint.items()]
    labels = attrs["mujoco:actuator_label"].values if "mujoco:actuator_label" in attrs else []
    if not labels:
        notes.append("the MJCF has no <actuator>: every joint is driven by the task's actuator config, which must "
                     "give each an effort limit")
        return []
    actuators = []
    for i, label in enumerate(labels):
        if int(attrs["mujoco:actuator_trntype"].values[i]) != 0:  # a tendon, site or body transmission
            notes.append(f"actuator {label}: not on a joint (not checked)")
            continue
        dof = int(attrs["mujoco:actuator_trnid"].values[i][0])
        limited = int(attrs["mujoco:actuator_forcelimited"].values[i])  # 0 false, 1 true, 2 auto (has a range)
        effort = None
        if limited == 1 or (limited == 2 and int(attrs["mujoco:actuator_has_forcerange"].values[i])):
            low, high = attrs["mujoco:actuator_forcerange"].values[i]
            effort = float(min(abs(low), abs(high)))
        elif builder.joint_effort_limit[dof] < NO_EFFORT_LIMIT_NM:
            effort = float(builder.joint_effort_limit[dof])
        actuators.append(ActuatorInfo(label, dof_joint.get(dof, f"dof {dof}"), effort))
    return actuators


def _self_collisions(path: Path, joints: list[JointInfo], notes: list[str]) -> list[tuple[str, str]] | None:
    """Body pairs in contact at the default pose in plain MuJoCo (MJCF and URDF, with the file's own collision
    filter: contype/conaffinity, a body never collides with its parent); None for USD or a file MuJoCo refuses."""
    import mujoco

    if path.suffix.lower() in USD_SUFFIXES:
        notes.append("self-collision not checked: MuJoCo reads MJCF and URDF only")
        return None
    try:
        model = mujoco.MjModel.from_xml_path(str(path))
    except Exception as err:  # mujoco raises ValueError with the compiler's message
        notes.append(f"self-collision not checked: MuJoCo refused the file ({str(err).strip().splitlines()[0]})")
        return None
    data = mujoco.MjData(model)
    for joint in joints:
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
        if j >= 0 and model.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            data.qpos[model.jnt_qposadr[j]] = joint.default_pos_rad
    mujoco.mj_forward(model, data)
    pairs = set()
    for contact in data.contact[:data.ncon]:
        b1, b2 = model.geom_bodyid[contact.geom1], model.geom_bodyid[contact.geom2]
        if b1 == 0 or b2 == 0 or contact.dist >= 0.0:  # the world (a floor in the file), or within the margin only
            continue
        names = sorted(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, int(b)) for b in (b1, b2))
        pairs.add((names[0], names[1]))
    return sorted(pairs)


def format_report(report: RobotReport) -> str:
    """The report as the command prints it."""
    def num(value, fmt=".3g"):
        return "-" if value is None else format(value, fmt)

    lines = [f"model: {report.model_file}",
             f"root body: {report.root_body} ({'floating base' if report.floating_base else 'fixed to the world'})",
             f"joints ({len(report.joints)}): name, range [rad], armature [kg·m²], effort limit [N·m], "
             "velocity limit [rad/s], default [rad]"]
    width = max((len(j.name) for j in report.joints), default=4)
    for j in report.joints:
        lines.append(f"  {j.name:<{width}}  [{num(j.lower_rad, '.4g')}, {num(j.upper_rad, '.4g')}]  "
                     f"{num(j.armature_kgm2)}  {num(j.effort_limit_nm)}  {num(j.velocity_limit_radps)}  "
                     f"{j.default_pos_rad:.4g}")
    total = sum(b.mass_kg for b in report.bodies)
    lines.append(f"bodies ({len(report.bodies)}, {total:.3f} kg): name, mass [kg], principal inertia [kg·m²]")
    width = max((len(b.name) for b in report.bodies), default=4)
    for b in report.bodies:
        lines.append(f"  {b.name:<{width}}  {b.mass_kg:.4g}  " + " ".join(f"{v:.3g}" for v in b.principal_inertia_kgm2))
    lines.append(f"actuators ({len(report.actuators)}): name, joint, effort limit [N·m]")
    for a in report.actuators:
        lines.append(f"  {a.name}  {a.joint}  {num(a.effort_limit_nm)}")
    lines.append(f"default pose: base height {num(report.default_base_height_m, '.4f')} m above flat ground")
    lines.append(f"feet candidates (colliders within {FEET_TOLERANCE_M} m of the lowest point): "
                 f"{', '.join(report.feet_candidates) or '-'}")
    if report.self_collisions is not None:
        lines.append(f"self-collisions at the default pose: {len(report.self_collisions)}")
    lines += [f"note: {note}" for note in report.notes]
    if report.problems:
        lines.append(f"{len(report.problems)} problem(s):")
        lines += [f"  problem: {problem}" for problem in report.problems]
    else:
        lines.append("no problem found")
    return "\n".join(lines)
