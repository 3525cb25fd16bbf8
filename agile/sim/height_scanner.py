"""Height scan: a yaw-aligned grid of rays cast straight down from an entity's body onto the terrain.

The terrain is a height field, so a vertical ray hits it at the surface height under the ray, which is a
lookup with MuJoCo's triangulation of the grid: no ray marching, no scene query, no host sync. The result
is exact for the terrain and ignores the robots (as Isaac Lab's RayCaster, which only sees the ground).
Without a terrain the ground is the plane z=0.
"""

from __future__ import annotations

import torch
import warp as wp

from agile.sim.entities.entity import Entity
from agile.sim.scene_cfg import HeightScannerCfg
from agile.sim.terrain_contacts import heightfield_cell
from agile.utils.warp_math import yaw_of


class TerrainHeights:
    """Surface height z(x, y) of a height field (`terrain_height` in a Warp kernel reads it).

    Each grid cell is split into two triangles along the diagonal from (i, j+1) to (i+1, j), as MuJoCo
    builds its height-field prisms, so that the scan agrees with the collision surface.
    """

    def __init__(self, heights_m: torch.Tensor, origin_xy_m: tuple[float, float], horizontal_scale_m: float):
        self.heights_m = heights_m.contiguous()
        self.heights_wp = wp.from_torch(self.heights_m)
        self.num_x, self.num_y = heights_m.shape
        self.origin_xy_m = origin_xy_m
        self.horizontal_scale_m = horizontal_scale_m


@wp.func
def terrain_height(heights_m: wp.array2d(dtype=float), origin_x_m: float, origin_y_m: float, scale_m: float,
                   x_m: float, y_m: float) -> float:
    """The height field's surface height at (x, y) [m], on the triangle of its cell under (x, y) (`heightfield_cell`,
    as the terrain contacts see it)."""
    row, col, fu, fv = heightfield_cell(heights_m, origin_x_m, origin_y_m, scale_m, x_m, y_m)
    z00, z10 = heights_m[row, col], heights_m[row + 1, col]
    z01, z11 = heights_m[row, col + 1], heights_m[row + 1, col + 1]
    if fu + fv <= 1.0:
        return z00 + fu * (z10 - z00) + fv * (z01 - z00)
    return z11 + (1.0 - fu) * (z01 - z11) + (1.0 - fv) * (z10 - z11)


@wp.kernel(enable_backward=False)
def _scan(body_pose_w: wp.array2d(dtype=float), ray_offsets_b: wp.array2d(dtype=float),
          heights_m: wp.array2d(dtype=float), has_terrain: int, origin_x_m: float, origin_y_m: float,
          scale_m: float, pos_w: wp.array2d(dtype=float), ray_xy_w: wp.array3d(dtype=float),
          hit_z_m: wp.array2d(dtype=float)):
    env, ray = wp.tid()
    px, py = body_pose_w[env, 0], body_pose_w[env, 1]
    yaw = yaw_of(body_pose_w[env, 3], body_pose_w[env, 4], body_pose_w[env, 5], body_pose_w[env, 6])
    cos_yaw, sin_yaw = wp.cos(yaw), wp.sin(yaw)
    dx, dy = ray_offsets_b[ray, 0], ray_offsets_b[ray, 1]
    x = px + cos_yaw * dx - sin_yaw * dy
    y = py + sin_yaw * dx + cos_yaw * dy
    ray_xy_w[env, ray, 0] = x
    ray_xy_w[env, ray, 1] = y
    z = 0.0
    if has_terrain:
        z = terrain_height(heights_m, origin_x_m, origin_y_m, scale_m, x, y)
    hit_z_m[env, ray] = z
    if ray == 0:
        for k in range(3):
            pos_w[env, k] = body_pose_w[env, k]


def grid_pattern(size_m: tuple[float, float], resolution_m: float, device) -> torch.Tensor:
    """(R, 2) ray offsets, Isaac Lab's GridPattern order (x fastest); (0, 0) gives one ray."""
    if not resolution_m > 0.0:
        raise ValueError(f"height scanner resolution_m must be > 0, got {resolution_m}")
    if not (size_m[0] >= 0.0 and size_m[1] >= 0.0):
        raise ValueError(f"height scanner size_m must be >= 0 along x and y, got {tuple(size_m)}")
    xs = torch.arange(-size_m[0] / 2, size_m[0] / 2 + 1e-9, resolution_m, device=device)
    ys = torch.arange(-size_m[1] / 2, size_m[1] / 2 + 1e-9, resolution_m, device=device)
    grid_x, grid_y = torch.meshgrid(xs, ys, indexing="xy")
    return torch.stack((grid_x.flatten(), grid_y.flatten()), dim=1)


class HeightScanner:
    """Terrain heights under a ray grid that follows one body's position and yaw.

    Buffers, refreshed by `update()` in place (fixed shapes, for the captured step):
    - `pos_w` (N, 3): the sensor position, the body's position [m].
    - `ray_xy_w` (N, R, 2): where the rays hit, in xy [m].
    - `hit_z_m` (N, R): terrain height at each ray [m].
    - `base_height_m` (N,): body height above the mean hit height [m] (AGILE base_height_from_sensor).
    """

    def __init__(self, cfg: HeightScannerCfg, entity: Entity, terrain: TerrainHeights | None):
        ids, names = entity.find_bodies(cfg.body_name)
        if len(ids) != 1:
            raise ValueError(f"height scanner body_name '{cfg.body_name}' must match one body, matched {names}")
        self.cfg = cfg
        self.body_id = ids[0]
        self.entity = entity
        self.terrain = terrain
        device = entity.device
        offset = torch.tensor(cfg.offset_xy_m, dtype=torch.float32, device=device)
        self.ray_offsets_b = grid_pattern(cfg.size_m, cfg.resolution_m, device) + offset
        self.num_rays = self.ray_offsets_b.shape[0]
        n = entity.num_envs
        self.pos_w = torch.zeros(n, 3, device=device)
        self.ray_xy_w = torch.zeros(n, self.num_rays, 2, device=device)
        self.hit_z_m = torch.zeros(n, self.num_rays, device=device)
        self.base_height_m = torch.zeros(n, device=device)
        # Warp views made once (the body's pose is a view of the simulation state)
        heights = terrain.heights_wp if terrain is not None else wp.zeros((1, 1), dtype=float, device=entity.wp_device)
        origin, scale = (terrain.origin_xy_m, terrain.horizontal_scale_m) if terrain is not None else ((0.0, 0.0), 1.0)
        self._scan_args = [wp.from_torch(entity.body_pose_w[:, self.body_id]), wp.from_torch(self.ray_offsets_b),
                           heights, int(terrain is not None), float(origin[0]), float(origin[1]), float(scale),
                           wp.from_torch(self.pos_w), wp.from_torch(self.ray_xy_w), wp.from_torch(self.hit_z_m)]
        self._wp_device = entity.wp_device

    def update(self) -> None:
        """Ray positions and hit heights in one kernel, then the base height (their mean under the body)."""
        wp.launch(_scan, dim=(self.entity.num_envs, self.num_rays), inputs=self._scan_args, device=self._wp_device)
        torch.sub(self.pos_w[:, 2], self.hit_z_m.mean(dim=1), out=self.base_height_m)
