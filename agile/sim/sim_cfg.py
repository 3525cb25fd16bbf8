"""Configuration of the Newton world: robot, ground, solver and rates."""

from __future__ import annotations

from dataclasses import field

from agile.actuators import ImplicitActuatorCfg
from agile.sim.terrain import TerrainGeneratorCfg
from agile.utils.config import configclass


@configclass
class RobotCfg:
    """A robot loaded from a model file (MJCF, URDF or USD) through Newton's importers."""

    model_file: str = ""
    """Path of the MJCF (.xml), URDF (.urdf) or USD (.usd, .usda, .usdc) file."""
    init_pos_m: tuple[float, float, float] = (0.0, 0.0, 0.7)
    """Root position of the default state, relative to the env origin."""
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
    """MuJoCo `condim` for every robot collider (3 = friction cone); None keeps the file's."""
    self_collisions: bool = False
    parse_visuals: bool = False
    """Visual meshes are only needed for rendering; headless training skips them."""


@configclass
class SolverCfg:
    """`newton.solvers.SolverMuJoCo` settings (per task)."""

    iterations: int = 10
    ls_iterations: int = 20
    njmax: int = 150  # constraint rows per world
    nconmax: int = 40  # contacts per world
    cone: str = "pyramidal"
    impratio: float = 1.0
    integrator: str = "implicitfast"
    solver: str = "newton"


@configclass
class ContactSensorCfg:
    """Contact forces on robot bodies (Isaac Lab ContactSensorCfg); terms find it as env.scene["contact_forces"]."""

    body_names: str | list[str] = ".*"
    """Regexes of the robot bodies to sense; terms select among these by name."""
    history_length: int = 3
    """Physics steps of net force kept in `net_forces_w_history` (AGILE: 3)."""
    track_air_time: bool = True
    force_threshold_n: float = 1.0
    """A body is in contact above this net force [N] (for air and contact times)."""


@configclass
class HeightScannerCfg:
    """A grid of rays cast straight down from a robot body onto the terrain (Isaac Lab RayCaster with a
    GridPattern and `ray_alignment="yaw"`); terms find it as env.sim.height_scanners[name]."""

    body_name: str = ""
    """Regex of the one robot body the grid follows."""
    offset_xy_m: tuple[float, float] = (0.0, 0.0)
    """Grid centre relative to the body, in the body's yaw frame. There is no z offset: rays start above
    all terrain, and the sensor height is the body's."""
    size_m: tuple[float, float] = (0.0, 0.0)
    """Grid extent along x and y in the yaw frame; (0, 0) is a single ray."""
    resolution_m: float = 0.1


@configclass
class SimCfg:
    physics_dt_s: float = 0.005
    solver: SolverCfg = SolverCfg()
    contact_sensor: ContactSensorCfg | None = None
    """None: no contact forces are read (saves the per-step export)."""
    use_graph: bool = True
    """Capture the decimation loop once as a Warp graph (CUDA graph on GPU, APIC graph on CPU)."""
    ground_friction: float = 1.0
    """Friction of the ground plane, or of the terrain."""
    terrain: TerrainGeneratorCfg | None = None
    """None: a flat ground plane at z=0. Else a generated height field; envs spawn at its cells."""
    terrain_contact_gap_m: float = 0.02
    """Speculative contact distance of every shape on a terrain (Newton `shape_gap`; its default is 0.1 m).
    Newton's pipeline collects contacts against every terrain triangle within this distance: 0.1 m cost
    3-4x the contacts and 5-6x the collision time of 0.02 m (CPU, 64 worlds). 0.02 m is 4 physics steps of
    a foot at 1 m/s, or one at 4 m/s."""
    max_init_terrain_level: int | None = None
    """Envs start on a row drawn from [0, this]; None allows every row."""
    height_scanners: dict[str, HeightScannerCfg] = field(default_factory=dict)
    env_spacing_m: float = 2.5
    gravity_mps2: float = -9.81
