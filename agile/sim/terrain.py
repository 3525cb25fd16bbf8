"""Terrain generator: a grid of sub-terrain cells sampled into one height field.

Rows (x) are difficulty levels, columns (y) are terrain types by proportion, as in Isaac Lab's
`TerrainGenerator`. The result is a height field, not a triangle mesh: SolverMuJoCo collides MuJoCo
height fields with every primitive collider (box, capsule, sphere, mesh) exactly, through one convex
prism per triangle, whereas a triangle mesh would be collided as its convex hull. The price is that
vertical faces (stair risers, box sides) become slopes one sample wide (`horizontal_scale_m`).

Heights are `heights_m[ix, iy]` at world x = `origin_xy_m[0] + ix * horizontal_scale_m` (likewise y),
and the grid is centred on the world origin. Each cell's origin (where envs spawn) is its centre, at the
highest point of the central 1 m square.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import zipfile
import zlib
from dataclasses import field
from pathlib import Path

import numpy as np

from agile.sim.sub_terrains import (  # noqa: F401 (re-exported: the sub-terrains with the generator)
    BoxGridTerrainCfg, FlatTerrainCfg, PyramidSlopeTerrainCfg, PyramidStairsTerrainCfg, RandomUniformTerrainCfg,
    SubTerrainCfg, WaveTerrainCfg)
from agile.utils.config import ConfigError, configclass, to_dict
from agile.utils.files import warn_if_untrusted_folder

CACHE_VERSION = 2
"""Bump when the meaning of a config field changes, so old cache files are not reused."""

ORIGIN_PATCH_M = 1.0
"""Side of the central square whose highest point is the cell origin (Isaac Lab's height-field rule)."""


# -- generator ---------------------------------------------------------------------------------------


@configclass
class TerrainGeneratorCfg:
    size_m: float = 8.0
    """Side of one square sub-terrain cell."""
    num_rows: int = 10
    """Difficulty levels (along x)."""
    num_cols: int = 20
    """Cells per level (along y); with the curriculum, columns are split among types by proportion."""
    border_width_m: float = 20.0
    """Flat ring at height 0 around the grid (Isaac Lab ROUGH_TERRAINS_CFG), for envs that walk off it."""
    horizontal_scale_m: float = 0.1
    """Sample spacing of the height field (Isaac Lab's default)."""
    curriculum: bool = True
    """Rows get increasing difficulty and columns fixed types; else both are drawn per cell."""
    difficulty_range: tuple[float, float] = (0.0, 1.0)
    seed: int = 0
    sub_terrains: dict[str, SubTerrainCfg] = field(default_factory=lambda: {"flat": FlatTerrainCfg()})


@dataclasses.dataclass
class TerrainData:
    heights_m: np.ndarray
    """(nx, ny) float32 heights; x along rows."""
    origin_xy_m: tuple[float, float]
    """World xy of heights_m[0, 0]."""
    horizontal_scale_m: float
    cell_origins_m: np.ndarray
    """(num_rows, num_cols, 3) float32 spawn points."""
    cell_types: np.ndarray
    """(num_rows, num_cols) int32 index into type_names."""
    cell_difficulty: np.ndarray
    """(num_rows, num_cols) float32."""
    type_names: list[str]

    ARRAYS = ("heights_m", "cell_origins_m", "cell_types", "cell_difficulty")

    def height_at(self, x_m: float, y_m: float) -> float:
        """Height of the surface at a world point with MuJoCo's triangulation (for tests and tools)."""
        u = (x_m - self.origin_xy_m[0]) / self.horizontal_scale_m
        v = (y_m - self.origin_xy_m[1]) / self.horizontal_scale_m
        nx, ny = self.heights_m.shape
        u, v = min(max(u, 0.0), nx - 1.0001), min(max(v, 0.0), ny - 1.0001)
        i, j = int(u), int(v)
        fu, fv = u - i, v - j
        h = self.heights_m
        if fu + fv <= 1.0:
            return float(h[i, j] + fu * (h[i + 1, j] - h[i, j]) + fv * (h[i, j + 1] - h[i, j]))
        return float(h[i + 1, j + 1] + (1 - fu) * (h[i, j + 1] - h[i + 1, j + 1])
                     + (1 - fv) * (h[i + 1, j] - h[i + 1, j + 1]))


def _cell_layout(cfg: TerrainGeneratorCfg, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(types, difficulty) per cell. Curriculum (Isaac Lab's rules): row r's cells have difficulties drawn in
    [r, r + 1) / num_rows, so that columns of one type differ, and column c the type whose cumulative
    proportion first exceeds c / num_cols."""
    proportions = np.array([s.proportion for s in cfg.sub_terrains.values()], dtype=np.float64)
    if (proportions < 0).any() or proportions.sum() <= 0:
        raise ValueError(f"sub-terrain proportions must be >= 0 with a positive sum, got {proportions.tolist()}")
    proportions /= proportions.sum()
    shape = (cfg.num_rows, cfg.num_cols)
    if cfg.curriculum:
        cumulative = np.cumsum(proportions)
        col_types = [int(np.argmax(c / cfg.num_cols + 0.001 < cumulative)) for c in range(cfg.num_cols)]
        types = np.broadcast_to(np.array(col_types), shape).copy()
        difficulty = (np.arange(cfg.num_rows)[:, None] + rng.uniform(0.0, 1.0, size=shape)) / cfg.num_rows
    else:
        types = rng.choice(len(proportions), size=shape, p=proportions)
        difficulty = rng.uniform(0.0, 1.0, size=shape)
    low, high = cfg.difficulty_range
    return types.astype(np.int32), (low + difficulty * (high - low)).astype(np.float32)


def generate_terrain(cfg: TerrainGeneratorCfg) -> TerrainData:
    """Sample every cell into one height field; deterministic in `cfg` (including `cfg.seed`)."""
    if not cfg.sub_terrains:
        raise ValueError("a terrain needs at least one sub-terrain")
    h = cfg.horizontal_scale_m
    n = round(cfg.size_m / h)
    if not math.isclose(n * h, cfg.size_m, rel_tol=1e-6):
        raise ValueError(f"size_m {cfg.size_m} is not a multiple of horizontal_scale_m {h}")
    nb = round(cfg.border_width_m / h)
    types, difficulty = _cell_layout(cfg, np.random.default_rng([cfg.seed, 0]))
    subs = list(cfg.sub_terrains.values())
    # one sample more than the cells span, so that the far edge of the grid has a height too
    heights = np.zeros((cfg.num_rows * n + 2 * nb + 1, cfg.num_cols * n + 2 * nb + 1), dtype=np.float32)
    origin_xy = (-(cfg.num_rows * n / 2 + nb) * h, -(cfg.num_cols * n / 2 + nb) * h)
    local = (np.arange(n) - n / 2) * h  # cell-local sample coordinates, centre at 0
    x_m, y_m = np.meshgrid(local, local, indexing="ij")
    origins = np.zeros((cfg.num_rows, cfg.num_cols, 3), dtype=np.float32)
    patch = (np.abs(x_m) <= ORIGIN_PATCH_M / 2) & (np.abs(y_m) <= ORIGIN_PATCH_M / 2)
    for row in range(cfg.num_rows):
        for col in range(cfg.num_cols):
            rng = np.random.default_rng([cfg.seed, 1, row, col])  # per cell: independent of the other cells
            z = subs[types[row, col]].heights(float(difficulty[row, col]), x_m, y_m, cfg.size_m, rng)
            i0, j0 = nb + row * n, nb + col * n
            heights[i0:i0 + n, j0:j0 + n] = z
            origins[row, col] = ((row + 0.5) * n * h + nb * h + origin_xy[0],
                                 (col + 0.5) * n * h + nb * h + origin_xy[1], z[patch].max())
    return TerrainData(heights_m=heights, origin_xy_m=origin_xy, horizontal_scale_m=h, cell_origins_m=origins,
                       cell_types=types, cell_difficulty=difficulty, type_names=list(cfg.sub_terrains))


# -- cache -------------------------------------------------------------------------------------------


def cache_key(cfg: TerrainGeneratorCfg) -> str:
    """Hash of everything that shapes the terrain: the config (sub-terrain classes by name), the version."""
    payload = {"version": CACHE_VERSION, "cfg": to_dict(cfg),
               "types": {name: type(s).__qualname__ for name, s in cfg.sub_terrains.items()}}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:24]


def cache_dir() -> Path:
    return Path(os.environ.get("AGILE_CACHE_DIR", Path.home() / ".cache" / "agile")) / "terrain"


def _checksum(arrays: dict[str, np.ndarray]) -> str:
    digest = hashlib.sha256()
    for name in TerrainData.ARRAYS:
        digest.update(np.ascontiguousarray(arrays[name]).tobytes())
    return digest.hexdigest()


def check_terrain_cfg(cfg: TerrainGeneratorCfg) -> None:
    """Fields with a domain, checked before anything is generated or cached; the error names the field."""
    problems = []
    for name in ("num_rows", "num_cols"):
        if getattr(cfg, name) < 1:
            problems.append(f"{name} must be at least 1, got {getattr(cfg, name)}")
    for name in ("size_m", "horizontal_scale_m"):
        if not getattr(cfg, name) > 0:
            problems.append(f"{name} must be positive, got {getattr(cfg, name)}")
    for name in ("border_width_m", "seed"):
        if getattr(cfg, name) < 0:
            problems.append(f"{name} must be >= 0, got {getattr(cfg, name)}")
    h = cfg.horizontal_scale_m
    if cfg.size_m > 0 and h > 0 and not math.isclose(round(cfg.size_m / h) * h, cfg.size_m, rel_tol=1e-6):
        problems.append(f"size_m {cfg.size_m} must be a multiple of horizontal_scale_m {h} (a cell is a whole "
                        f"number of samples)")
    low, high = cfg.difficulty_range
    if not 0.0 <= low <= high <= 1.0:
        problems.append(f"difficulty_range must be ordered within [0, 1], got {cfg.difficulty_range}")
    for name, sub_terrain in cfg.sub_terrains.items():
        problems += [f"sub_terrains.{name}.{problem}" for problem in sub_terrain.problems()]
    if not cfg.sub_terrains or sum(t.proportion for t in cfg.sub_terrains.values()) <= 0:
        problems.append("sub_terrains need a positive total proportion")
    if problems:
        raise ConfigError("scene.terrain." + "; scene.terrain.".join(problems))


def load_or_generate_terrain(cfg: TerrainGeneratorCfg, use_cache: bool = True) -> TerrainData:
    """Generate the terrain, or load it from the cache file named by `cache_key(cfg)`.

    A cache file stores a checksum of its arrays; a file that does not match (truncated, edited) is
    regenerated rather than trusted."""
    check_terrain_cfg(cfg)
    if not use_cache:
        return generate_terrain(cfg)
    path = cache_dir() / f"terrain_{cache_key(cfg)}.npz"
    if path.is_file():
        warn_if_untrusted_folder(path.parent, "a cached terrain")
        try:
            with np.load(path) as f:
                arrays = {name: f[name] for name in TerrainData.ARRAYS}
                meta = json.loads(str(f["meta"]))
            if meta["checksum"] == _checksum(arrays):
                return TerrainData(origin_xy_m=tuple(meta["origin_xy_m"]), type_names=meta["type_names"],
                                   horizontal_scale_m=meta["horizontal_scale_m"], **arrays)
            print(f"[agile] cached terrain {path} does not match its checksum: generating it again")
        except (OSError, EOFError, KeyError, ValueError, zipfile.BadZipFile, zlib.error) as err:
            print(f"[agile] cached terrain {path} cannot be read ({type(err).__name__}): generating it again")
    data = generate_terrain(cfg)
    arrays = {name: getattr(data, name) for name in TerrainData.ARRAYS}
    meta = {"checksum": _checksum(arrays), "origin_xy_m": list(data.origin_xy_m),
            "horizontal_scale_m": data.horizontal_scale_m, "type_names": data.type_names}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.stem}.{os.getpid()}.tmp.npz")  # atomic: concurrent runs never read half a file
    np.savez(tmp, meta=json.dumps(meta), **arrays)
    os.replace(tmp, path)
    return data


# -- presets (AGILE terrains/terrains.py; sub-terrain values from AGILE unless noted) ------------------
# AGILE builds its boxes as meshes and uses a 100 m border with 0.4 m height-field samples. Here everything
# is one height field with Isaac Lab's 0.1 m samples (AGILE's 0.15 m, 0-2 cm boxes become bumps one or two
# samples wide) and Isaac Lab's 20 m border, more than an env walks in an episode. The random bumps keep
# AGILE's 0.4 m between drawn heights (`sample_spacing_m`), so their slopes are AGILE's.

LESS_ROUGH_TERRAIN_CFG = TerrainGeneratorCfg(
    size_m=8.0, num_rows=20, num_cols=16, horizontal_scale_m=0.1,
    sub_terrains={
        "boxes_small": BoxGridTerrainCfg(proportion=0.2, grid_width_m=0.15, grid_height_range_m=(0.0, 0.02),
                                         platform_width_m=0.1),
        "random_rough_small": RandomUniformTerrainCfg(proportion=1.0, noise_range_m=(0.01, 0.1), noise_step_m=0.1,
                                                      border_width_m=0.4, sample_spacing_m=0.4),
    },
)

MEDIUM_ROUGH_TERRAIN_CFG = TerrainGeneratorCfg(
    size_m=8.0, num_rows=20, num_cols=15, horizontal_scale_m=0.1,
    sub_terrains={
        "boxes_small": BoxGridTerrainCfg(proportion=0.2, grid_width_m=0.15, grid_height_range_m=(0.0, 0.04),
                                         platform_width_m=0.1),
        "random_rough_small": RandomUniformTerrainCfg(proportion=0.2, noise_range_m=(0.01, 0.2), noise_step_m=0.1,
                                                      border_width_m=0.4, sample_spacing_m=0.4),
        "wave_small": WaveTerrainCfg(proportion=0.2, amplitude_range_m=(0.01, 0.25), num_waves=3),
    },
)

# agile_tasks.md 2.4: 8 x 9 cells; boxes_small, rough and wave at 0.3 each, wave amplitude 0.01-0.15 m.
# The box and rough values it does not give are LESS_ROUGH's above.
STAND_UP_ROUGH_TERRAIN_CFG = TerrainGeneratorCfg(
    size_m=8.0, num_rows=8, num_cols=9, horizontal_scale_m=0.1,
    sub_terrains={
        "boxes_small": BoxGridTerrainCfg(proportion=0.3, grid_width_m=0.15, grid_height_range_m=(0.0, 0.02),
                                         platform_width_m=0.1),
        "random_rough_small": RandomUniformTerrainCfg(proportion=0.3, noise_range_m=(0.01, 0.1), noise_step_m=0.1,
                                                      border_width_m=0.4),
        "wave_small": WaveTerrainCfg(proportion=0.3, amplitude_range_m=(0.01, 0.15), num_waves=3),
    },
)

# AGILE V1.3 HeightTracking-G1's terrain: the reference gives its grid (8 x 8 m cells, 8 rows x 9 columns: 72 tiles)
# but not its sub-terrains, so it is T1's stand-up terrain, which has the same grid.
STAND_UP_ROUGH_TERRAIN_G1_CFG = STAND_UP_ROUGH_TERRAIN_CFG

# Isaac Lab ROUGH_TERRAINS_CFG, all types this generator has (its mesh stairs and boxes as height fields).
ROUGH_TERRAINS_CFG = TerrainGeneratorCfg(
    size_m=8.0, num_rows=10, num_cols=20, horizontal_scale_m=0.1,
    sub_terrains={
        "pyramid_stairs": PyramidStairsTerrainCfg(proportion=0.2, step_height_range_m=(0.05, 0.23), step_width_m=0.3,
                                                  platform_width_m=3.0, border_width_m=1.0),
        "pyramid_stairs_inv": PyramidStairsTerrainCfg(proportion=0.2, step_height_range_m=(0.05, 0.23),
                                                      step_width_m=0.3, platform_width_m=3.0, border_width_m=1.0,
                                                      inverted=True),
        "boxes": BoxGridTerrainCfg(proportion=0.2, grid_width_m=0.45, grid_height_range_m=(0.05, 0.2),
                                   platform_width_m=2.0),
        "random_rough": RandomUniformTerrainCfg(proportion=0.2, noise_range_m=(0.02, 0.10), noise_step_m=0.02,
                                                border_width_m=0.25),
        "hf_pyramid_slope": PyramidSlopeTerrainCfg(proportion=0.1, slope_range=(0.0, 0.4), platform_width_m=2.0,
                                                   border_width_m=0.25),
        "hf_pyramid_slope_inv": PyramidSlopeTerrainCfg(proportion=0.1, slope_range=(0.0, 0.4), platform_width_m=2.0,
                                                       border_width_m=0.25, inverted=True),
    },
)
