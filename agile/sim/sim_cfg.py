"""Configuration of the physics: solver and rates."""

from __future__ import annotations

from agile.utils.config import configclass


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
    """Physics settings; what the worlds hold is the scene's (`SceneCfg`)."""

    physics_dt_s: float = 0.005
    solver: SolverCfg = SolverCfg()
    use_graph: bool = True
    """Capture the decimation loop once as a Warp graph (CUDA graph on GPU, APIC graph on CPU)."""
    gravity_mps2: float = -9.81
