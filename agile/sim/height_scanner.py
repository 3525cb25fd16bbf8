"""Height scan: a yaw-aligned grid of rays cast straight down from an entity's body onto the terrain.

The terrain is a height field, so a vertical ray hits it at the surface height under the ray, which is a
lookup with MuJoCo's triangulation of the grid: no ray marching, no scene query, no host sync. The result
is exact for the terrain and ignores the robots (as Isaac Lab's RayCaster, which only sees the ground).
Without a terrain the ground is the plane z=0.
"""

from __future__ import annotations

import torch

from agile.sim.entities.entity import Entity
from agile.sim.scene_cfg import HeightScannerCfg
from agile.utils.math import yaw_from_quat


class TerrainHeights:
    """Surface height z(x, y) of a height field, as torch math on the sim device.

    Each grid cell is split into two triangles along the diagonal from (i, j+1) to (i+1, j), as MuJoCo
    builds its height-field prisms, so that the scan agrees with the collision surface.
    """

    def __init__(self, heights_m: torch.Tensor, origin_xy_m: tuple[float, float], horizontal_scale_m: float):
        self.heights_m = heights_m
        self.num_x, self.num_y = heights_m.shape
        self.origin_xy_m = origin_xy_m
        self.horizontal_scale_m = horizontal_scale_m

    def __call__(self, x_m: torch.Tensor, y_m: torch.Tensor) -> torch.Tensor:
        # outside the grid the border's edge height continues (the border is flat)
        u = ((x_m - self.origin_xy_m[0]) / self.horizontal_scale_m).clamp(0.0, self.num_x - 1.0001)
        v = ((y_m - self.origin_xy_m[1]) / self.horizontal_scale_m).clamp(0.0, self.num_y - 1.0001)
        i, j = u.floor(), v.floor()
        fu, fv = u - i, v - j
        flat = self.heights_m.view(-1)
        base = i.long() * self.num_y + j.long()
        z00, z10 = flat[base], flat[base + self.num_y]
        z01, z11 = flat[base + 1], flat[base + self.num_y + 1]
        lower = z00 + fu * (z10 - z00) + fv * (z01 - z00)
        upper = z11 + (1.0 - fu) * (z01 - z11) + (1.0 - fv) * (z10 - z11)
        return torch.where(fu + fv <= 1.0, lower, upper)


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

    def update(self) -> None:
        pose = self.entity.body_pose_w[:, self.body_id]
        yaw = yaw_from_quat(pose[:, 3:7]).unsqueeze(1)
        cos, sin = torch.cos(yaw), torch.sin(yaw)
        dx, dy = self.ray_offsets_b[:, 0], self.ray_offsets_b[:, 1]
        self.pos_w.copy_(pose[:, :3])
        self.ray_xy_w[..., 0] = pose[:, 0:1] + cos * dx - sin * dy
        self.ray_xy_w[..., 1] = pose[:, 1:2] + sin * dx + cos * dy
        if self.terrain is None:
            self.hit_z_m.zero_()
        else:
            self.hit_z_m.copy_(self.terrain(self.ray_xy_w[..., 0], self.ray_xy_w[..., 1]))
        torch.sub(self.pos_w[:, 2], self.hit_z_m.mean(dim=1), out=self.base_height_m)
