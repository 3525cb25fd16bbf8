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

from agile.utils.config import ConfigError, configclass, domain_problems, to_dict
from agile.utils.files import warn_if_untrusted_folder

CACHE_VERSION = 2
"""Bump when the meaning of a config field changes, so old cache files are not reused."""

ORIGIN_PATCH_M = 1.0
"""Side of the central square whose highest point is the cell origin (Isaac Lab's height-field rule)."""


# -- sub-terrains ------------------------------------------------------------------------------------
# Each sub-terrain config's `heights(difficulty, x_m, y_m, size_m, rng)` gives the height at cell-local
# coordinates (origin at the cell centre). Random ones draw from `rng`, which is seeded per cell.


def _lerp(value_range: tuple[float, float], t: float) -> float:
    return value_range[0] + t * (value_range[1] - value_range[0])


@configclass
class SubTerrainCfg:
    proportion: float = 1.0
    """Share of the columns (curriculum) or of the cells (random layout) of this type."""
    border_width_m: float = 0.0
    """Flat ring at height 0 along the cell edge."""

    def problems(self) -> list[str]:
        """Fields outside their domain, each message naming the field (checked before anything is generated)."""
        return domain_problems(self, non_negative=("proportion", "border_width_m"))

    def _inside(self, x_m: np.ndarray, y_m: np.ndarray, size_m: float) -> np.ndarray:
        half = size_m / 2 - self.border_width_m
        return (np.abs(x_m) < half) & (np.abs(y_m) < half)


@configclass
class FlatTerrainCfg(SubTerrainCfg):
    def heights(self, difficulty, x_m, y_m, size_m, rng):
        return np.zeros_like(x_m)


@configclass
class RandomUniformTerrainCfg(SubTerrainCfg):
    """AGILE's `HfRandomUniformTerrainDifficultyCfg`: heights drawn from {min, min + step, ..., max} with the
    whole range (and the step) scaled by the difficulty, one per sample or one every `sample_spacing_m` with
    the surface linear in between."""

    noise_range_m: tuple[float, float] = (0.02, 0.10)
    noise_step_m: float = 0.02
    min_step_m: float = 0.005
    """Smallest height step (Isaac Lab's vertical_scale): keeps the step non-zero at difficulty 0."""
    sample_spacing_m: float | None = None
    """Distance between drawn heights (Isaac Lab's `downsampled_scale`); None: every sample. AGILE's rough
    presets draw every 0.4 m (their height-field spacing); drawn every 0.1 m the same heights make 4x steeper
    bumps."""

    def problems(self) -> list[str]:
        # a zero step would make the list of height levels endless
        return super().problems() + domain_problems(self, positive=("min_step_m", "sample_spacing_m"),
                                                    non_negative=("noise_step_m",), ordered=("noise_range_m",))

    def heights(self, difficulty, x_m, y_m, size_m, rng):
        low, high = self.noise_range_m[0] * difficulty, self.noise_range_m[1] * difficulty
        step = max(self.noise_step_m * difficulty, self.min_step_m)
        levels = np.arange(low, high + step / 2, step)
        if self.sample_spacing_m is None:
            z = rng.choice(levels, size=x_m.shape)
        else:
            z = _bilinear(rng.choice(levels, size=(round(size_m / self.sample_spacing_m) + 1,) * 2),
                          (x_m + size_m / 2) / self.sample_spacing_m, (y_m + size_m / 2) / self.sample_spacing_m)
        return np.where(self._inside(x_m, y_m, size_m), z, 0.0)


def _bilinear(grid: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """`grid` (n, n) sampled at fractional indices (u, v), linear between its points."""
    i = np.clip(np.floor(u).astype(int), 0, grid.shape[0] - 2)
    j = np.clip(np.floor(v).astype(int), 0, grid.shape[1] - 2)
    fu, fv = u - i, v - j
    return ((1 - fu) * (1 - fv) * grid[i, j] + fu * (1 - fv) * grid[i + 1, j]
            + (1 - fu) * fv * grid[i, j + 1] + fu * fv * grid[i + 1, j + 1])


@configclass
class BoxGridTerrainCfg(SubTerrainCfg):
    """Isaac Lab's `MeshRandomGridTerrainCfg` as a height field: square blocks of `grid_width_m` with heights
    uniform in [-h, h], h from `grid_height_range_m` by difficulty; a flat platform in the centre.
    Block edges fall on samples, so a block is a whole number of samples wide (rounded up)."""

    grid_width_m: float = 0.45
    grid_height_range_m: tuple[float, float] = (0.05, 0.2)
    platform_width_m: float = 2.0

    def problems(self) -> list[str]:
        problems = super().problems() + domain_problems(self, positive=("grid_width_m",),
                                                        non_negative=("platform_width_m",),
                                                        ordered=("grid_height_range_m",))
        if self.grid_height_range_m[0] < 0:  # the half-height of a uniform draw in [-h, h]
            problems.append(f"grid_height_range_m must be >= 0, got {tuple(self.grid_height_range_m)}")
        return problems

    def heights(self, difficulty, x_m, y_m, size_m, rng):
        h = _lerp(self.grid_height_range_m, difficulty)
        blocks = math.ceil(size_m / self.grid_width_m)
        block_z = rng.uniform(-h, h, size=(blocks, blocks))
        ix = np.clip(((x_m + size_m / 2) // self.grid_width_m).astype(int), 0, blocks - 1)
        iy = np.clip(((y_m + size_m / 2) // self.grid_width_m).astype(int), 0, blocks - 1)
        z = block_z[ix, iy]
        platform = (np.abs(x_m) < self.platform_width_m / 2) & (np.abs(y_m) < self.platform_width_m / 2)
        return np.where(self._inside(x_m, y_m, size_m) & ~platform, z, 0.0)


@configclass
class WaveTerrainCfg(SubTerrainCfg):
    """Isaac Lab's `HfWaveTerrainCfg`: z = A/2 (cos(k y) + sin(k x)), k = 2 pi num_waves / size, x and y from
    the cell corner; the amplitude A from `amplitude_range_m` by difficulty."""

    amplitude_range_m: tuple[float, float] = (0.0, 0.2)
    num_waves: int = 1

    def problems(self) -> list[str]:
        return super().problems() + domain_problems(self, ordered=("amplitude_range_m",))

    def heights(self, difficulty, x_m, y_m, size_m, rng):
        amplitude = _lerp(self.amplitude_range_m, difficulty)
        k = 2 * math.pi * self.num_waves / size_m
        z = 0.5 * amplitude * (np.cos(k * (y_m + size_m / 2)) + np.sin(k * (x_m + size_m / 2)))
        return np.where(self._inside(x_m, y_m, size_m), z, 0.0)


@configclass
class PyramidSlopeTerrainCfg(SubTerrainCfg):
    """Four planar faces of gradient `slope` (rise over run, from `slope_range` by difficulty) rising from
    the border to a square platform; `inverted` digs the pyramid down instead."""

    slope_range: tuple[float, float] = (0.0, 0.4)
    platform_width_m: float = 2.0
    inverted: bool = False

    def problems(self) -> list[str]:
        return super().problems() + domain_problems(self, non_negative=("platform_width_m",), ordered=("slope_range",))

    def heights(self, difficulty, x_m, y_m, size_m, rng):
        slope = _lerp(self.slope_range, difficulty)
        run_m = size_m / 2 - self.border_width_m - self.platform_width_m / 2
        distance_to_border_m = size_m / 2 - self.border_width_m - np.maximum(np.abs(x_m), np.abs(y_m))
        z = slope * np.clip(distance_to_border_m, 0.0, run_m)
        return -z if self.inverted else z


@configclass
class PyramidStairsTerrainCfg(SubTerrainCfg):
    """Isaac Lab's `MeshPyramidStairsTerrainCfg`: square rings of `step_width_m`, each `step_height_m` (from
    the range by difficulty) above the outer one, up to a central platform; `inverted` goes down."""

    step_height_range_m: tuple[float, float] = (0.05, 0.23)
    step_width_m: float = 0.3
    platform_width_m: float = 3.0
    inverted: bool = False

    def problems(self) -> list[str]:
        return super().problems() + domain_problems(self, positive=("step_width_m",),
                                                    non_negative=("platform_width_m",), ordered=("step_height_range_m",))

    def num_steps(self, size_m: float) -> int:
        return int((size_m - 2 * self.border_width_m - self.platform_width_m) // (2 * self.step_width_m))

    def heights(self, difficulty, x_m, y_m, size_m, rng):
        step_h = _lerp(self.step_height_range_m, difficulty)
        distance_to_border_m = size_m / 2 - self.border_width_m - np.maximum(np.abs(x_m), np.abs(y_m))
        steps = np.where(distance_to_border_m > 0, np.floor(distance_to_border_m / self.step_width_m) + 1, 0)
        z = step_h * np.minimum(steps, self.num_steps(size_m))
        return -z if self.inverted else z


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
