"""Sub-terrain configs: each gives the height of one cell of the terrain grid (`terrain.py` samples the cells into
one height field). `heights(difficulty, x_m, y_m, size_m, rng)` is the height at cell-local coordinates (origin at
the cell centre); random ones draw from `rng`, which is seeded per cell."""

from __future__ import annotations

import math

import numpy as np

from agile.utils.config import configclass, domain_problems

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
