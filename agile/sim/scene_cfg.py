"""What every world holds: named entities (articulations, rigid objects), the ground or terrain, and sensors.

The model users know is Isaac Lab's `InteractiveSceneCfg`. Every entity is replicated into every world;
its initial pose is relative to the env origin (a grid cell, or a terrain cell with a terrain), and a reset
puts it back there, so fixed entities (a fixed-base robot, a table) follow their env's origin too.
"""

from __future__ import annotations

from dataclasses import field

from agile.actuators import ImplicitActuatorCfg
from agile.sim.terrain import TerrainGeneratorCfg
from agile.utils.config import configclass

GROUND = "ground"
"""Name that a contact sensor's `filter_entity` uses for the ground plane or the terrain."""


@configclass
class ArticulationCfg:
    """A robot (or any jointed body tree) loaded from a model file (MJCF, URDF or USD) through Newton's importers."""

    model_file: str = ""
    """Path of the MJCF (.xml), URDF (.urdf) or USD (.usd, .usda, .usdc) file."""
    fixed_base: bool = False
    """True: the root is welded to the env at its initial pose (a robot on a stand); False: a free root."""
    init_pos_m: tuple[float, float, float] = (0.0, 0.0, 0.7)
    """Root position of the default state, relative to the env origin."""
    init_rot_xyzw: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    """Root orientation of the default state (quaternion x, y, z, w)."""
    init_joint_pos: dict[str, float] = field(default_factory=dict)
    """Default joint positions [rad] as {joint-name regex: value}; joints not named start at 0."""
    actuators: dict[str, ImplicitActuatorCfg] = field(default_factory=dict)
    """Actuator groups by name. Joints in no group keep the gains of the model file."""
    soft_joint_pos_limit_factor: float = 1.0
    """Isaac Lab `ArticulationCfg.soft_joint_pos_limit_factor`: the soft position limits (what the
    `joint_pos_limits` penalty measures against) are the model's limits shrunk about their midpoint by this
    factor (0.9 in AGILE's T1 and Isaac Lab's G1 configs); 1.0 penalises only motion beyond the hard limits."""
    enable_all_colliders: bool = False
    """Turn on collision for collider shapes the file disables (Menagerie `g1_mjx.xml` uses contype=0
    with explicit contact pairs, which Newton does not import)."""
    mjcf_collider_classes: tuple[str, ...] = ("collision",)
    """MJCF default classes whose geoms are colliders. Newton matches class names exactly, not their
    parents: list sub-classes too (Menagerie G1 puts its feet in `foot_box` and `foot_capsule`, children of
    `collision`), or their geoms are dropped with the visuals."""
    contact_dim: int | None = 3
    """MuJoCo `condim` for every collider (3 = friction cone); None keeps the file's."""
    collider_margin_m: float | None = None
    """Contact margin of every collider [m]; None keeps the file's. On flat ground (MuJoCo's own contacts) Newton
    zeroes a file's nonzero margin with one warning per geom; 0 there is what the solver uses anyway."""
    self_collisions: bool = False
    parse_visuals: bool = False
    """Visual meshes are only needed for rendering; headless training skips them."""


# -- rigid objects: one body, with one collision shape from a primitive, a mesh file or a model file ---------

@configclass
class BoxShapeCfg:
    size_m: tuple[float, float, float] = (0.1, 0.1, 0.1)
    """Full edge lengths along x, y, z."""


@configclass
class SphereShapeCfg:
    radius_m: float = 0.05


@configclass
class CapsuleShapeCfg:
    """A cylinder with hemispherical ends, along the body's z axis."""

    radius_m: float = 0.05
    half_height_m: float = 0.1
    """Half the length of the cylindrical part (the ends add a radius each)."""


@configclass
class CylinderShapeCfg:
    """Along the body's z axis."""

    radius_m: float = 0.05
    half_height_m: float = 0.1


@configclass
class MeshFileShapeCfg:
    """A triangle mesh loaded by trimesh (.obj, .stl, .ply, .glb, ...), used as a convex hull for contacts."""

    path: str = ""
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)


@configclass
class ModelFileShapeCfg:
    """The one body of an MJCF, URDF or USD file, with the file's shapes, mass and inertia."""

    path: str = ""


RigidShapeCfg = BoxShapeCfg | SphereShapeCfg | CapsuleShapeCfg | CylinderShapeCfg | MeshFileShapeCfg | ModelFileShapeCfg

BODY_TYPES = ("dynamic", "kinematic", "fixed")


@configclass
class RigidObjectCfg:
    """One rigid body (Isaac Lab `RigidObjectCfg`): an object to pick up, a table, a prop."""

    shape: RigidShapeCfg = BoxShapeCfg()
    body_type: str = "dynamic"
    """'dynamic' (moved by forces and contacts), 'kinematic' (moved only by writes of its root state, pushes
    what it touches) or 'fixed' (welded to the env at its initial pose)."""
    mass_kg: float | None = None
    """None: the mass follows from `density_kg_m3` and the shape's volume (as the inertia always does). A
    kinematic object has none (Newton's MuJoCo solver drives it as a mocap body)."""
    density_kg_m3: float = 1000.0
    friction: float = 1.0
    restitution: float = 0.0
    """Stored for Newton's other solvers; MuJoCo contacts do not model restitution."""
    init_pos_m: tuple[float, float, float] = (0.0, 0.0, 0.5)
    """Position of the default state, relative to the env origin."""
    init_rot_xyzw: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    contact_dim: int = 3
    """MuJoCo `condim` of the object's shapes (3 = friction cone)."""
    color_rgb: tuple[float, float, float] | None = None
    """Colour of the shape in camera images and viewers (0-1 per channel); None: Newton's palette."""


EntityCfg = ArticulationCfg | RigidObjectCfg


# -- sensors ------------------------------------------------------------------------------------------------

@configclass
class ContactSensorCfg:
    """Contact forces on an entity's bodies (Isaac Lab ContactSensorCfg); terms find it by its scene name."""

    entity: str = "robot"
    """The entity whose bodies are sensed."""
    body_names: str | list[str] = ".*"
    """Regexes of the entity's bodies to sense; terms select among these by name."""
    history_length: int = 3
    """Physics steps of net force kept in `net_forces_w_history` (AGILE: 3)."""
    track_air_time: bool = True
    force_threshold_n: float = 1.0
    """A body is in contact above this net force [N] (for air and contact times)."""
    filter_entity: str | None = None
    """Report forces from this entity alone as well (`force_matrix_w`), e.g. hand-object; 'ground' is the
    ground plane or terrain (foot-terrain). None: net forces only."""
    filter_body_names: str | list[str] = ".*"
    """Regexes of the filter entity's bodies (ignored for 'ground')."""


@configclass
class HeightScannerCfg:
    """A grid of rays cast straight down from a body onto the terrain (Isaac Lab RayCaster with a
    GridPattern and `ray_alignment="yaw"`); terms find it by its scene name."""

    entity: str = "robot"
    """The entity whose body the grid follows."""
    body_name: str = ""
    """Regex of the one body the grid follows."""
    offset_xy_m: tuple[float, float] = (0.0, 0.0)
    """Grid centre relative to the body, in the body's yaw frame. There is no z offset: rays start above
    all terrain, and the sensor height is the body's."""
    size_m: tuple[float, float] = (0.0, 0.0)
    """Grid extent along x and y in the yaw frame; (0, 0) is a single ray."""
    resolution_m: float = 0.1


@configclass
class CameraCfg:
    """A pinhole RGB camera fixed to a body, rendered for every env by Newton's Warp ray tracer
    (`newton.sensors.SensorCamera`, one view per world); terms find it by its scene name. The image is rendered when
    read (`Camera.rgb()`), at most once per env step.

    The intrinsics are an OpenCV calibration at `calibration_size_px`; the rendered `width` x `height` may differ
    (the rays scale with it), so a small image for a test keeps the field of view."""

    entity: str = "robot"
    body_name: str = ""
    """Regex of the one body the camera is fixed to."""
    offset_pos_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Camera position in the body frame."""
    pitch_down_rad: float = 0.0
    """The camera looks along the body's +x axis, tilted down about the body's y axis by this angle (image x to the
    body's right, image y down: the ROS optical convention)."""
    width: int = 640
    height: int = 480
    fx: float = 375.0
    fy: float = 375.0
    cx: float = 320.0
    cy: float = 240.0
    """OpenCV pinhole intrinsics [px] at `calibration_size_px`."""
    calibration_size_px: tuple[int, int] = (640, 480)


@configclass
class SceneCfg:
    """Every world's content. Entity and sensor names share one namespace: `env.scene[name]`."""

    entities: dict[str, EntityCfg] = field(default_factory=dict)
    """Articulations and rigid objects by name, replicated into every world in this order."""
    terrain: TerrainGeneratorCfg | None = None
    """None: a flat ground plane at z=0. Else a generated height field; envs spawn at its cells."""
    ground_friction: float = 1.0
    """Friction of the ground plane, or of the terrain."""
    terrain_contact_gap_m: float = 0.02
    """Speculative contact distance of every shape on a terrain (Newton `shape_gap`; its default is 0.1 m): a pair
    within the sum of its shapes' gaps makes a contact (which pushes only once it touches). Newton's pipeline
    collects contacts against every terrain triangle within it: 0.1 m cost 3-4x the contacts and 5-6x the
    collision time of 0.02 m (CPU, 64 worlds)."""
    terrain_collision: str = "probes"
    """How colliders meet a terrain. "probes" (`agile/sim/terrain_contacts.py`): a few points per sphere, capsule,
    box or cylinder collider against the height samples under them, the contacts MuJoCo's plane collision would
    give; "newton_pipeline": Newton's general collision pipeline, the height field as triangles (any collider
    type; several times dearer). Pairs that do not involve the terrain always go through Newton's pipeline."""
    max_init_terrain_level: int | None = None
    """Envs start on a row drawn from [0, this]; None allows every row."""
    env_spacing_m: float = 2.5
    """Distance between env origins on flat ground."""
    contact_sensors: dict[str, ContactSensorCfg] = field(default_factory=dict)
    height_scanners: dict[str, HeightScannerCfg] = field(default_factory=dict)
    cameras: dict[str, CameraCfg] = field(default_factory=dict)
