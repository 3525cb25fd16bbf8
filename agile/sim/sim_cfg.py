"""Configuration of the physics: solver and rates, and the check of a world's settings before it is built."""

from __future__ import annotations

from typing import TYPE_CHECKING

from agile.utils.config import ConfigError, configclass, domain_problems

if TYPE_CHECKING:
    from agile.sim.scene_cfg import SceneCfg


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


TERRAIN_COLLISIONS = ("probes", "newton_pipeline")


def check_physics_cfg(cfg: SimCfg, scene_cfg: SceneCfg) -> None:
    """Solver budgets and iterations of 0 run a world without contacts or constraint solving (MuJoCo prints an
    overflow every step instead of failing); MuJoCo warns that a friction of 0 may give NaN. Checked before anything
    is built."""
    problems = [f"sim.solver.{p}" for p in domain_problems(
        cfg.solver, positive=("iterations", "ls_iterations", "njmax", "nconmax", "impratio"))]
    problems += [f"scene.{p}" for p in domain_problems(scene_cfg, positive=("ground_friction",),
                                                       non_negative=("terrain_contact_gap_m",))]
    max_init_level = scene_cfg.max_init_terrain_level
    if max_init_level is not None and max_init_level < 0:  # checked before the terrain is built (seconds on a CPU)
        problems.append(f"scene.max_init_terrain_level must be >= 0 (or None: any row), got {max_init_level}")
    if scene_cfg.terrain_collision not in TERRAIN_COLLISIONS:
        problems.append(f"scene.terrain_collision must be one of {list(TERRAIN_COLLISIONS)}, "
                        f"got {scene_cfg.terrain_collision!r}")
    if problems:
        raise ConfigError("; ".join(problems))
