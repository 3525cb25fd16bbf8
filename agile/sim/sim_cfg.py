"""Configuration of the Newton world: robot, ground, solver and rates."""

from __future__ import annotations

from dataclasses import field

from agile.actuators import ImplicitActuatorCfg
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
class SimCfg:
    physics_dt_s: float = 0.005
    solver: SolverCfg = SolverCfg()
    use_graph: bool = True
    """Capture the decimation loop once as a Warp graph (CUDA graph on GPU, APIC graph on CPU)."""
    ground_friction: float = 1.0
    env_spacing_m: float = 2.5
    gravity_mps2: float = -9.81
