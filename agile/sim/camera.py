"""An RGB camera fixed to a body, one view per env, rendered by Newton's Warp ray tracer (`SensorCamera`).

Every env's view renders its own world (`SensorCamera`'s views map to worlds one to one), so N envs give N images of
N different scenes in one launch. The image is rendered when it is read and kept until the state changes
(`Scene.update` marks it stale): a recorder and an observation term reading it in one step pay one render.
"""

from __future__ import annotations

import math

import torch

from agile.sim.entities.entity import Entity
from agile.sim.scene_cfg import CameraCfg
from agile.utils.math import quat_mul, quat_rotate


def optical_frame_quat_xyzw(pitch_down_rad: float) -> tuple[float, float, float, float]:
    """Rotation from a body frame (x forward, y left, z up) to a Newton camera frame (looking along its -z, y up,
    x right) that looks along the body's +x tilted down by `pitch_down_rad`."""
    c, s = math.cos(pitch_down_rad), math.sin(pitch_down_rad)
    forward = (c, 0.0, -s)
    right = (0.0, -1.0, 0.0)
    up = (s, 0.0, c)  # right x up = -forward: a right-handed camera frame
    # columns: the camera's x (right), y (up) and z (backward) axes in the body frame
    m = [[right[i], up[i], -forward[i]] for i in range(3)]
    w = math.sqrt(max(1e-12, 1.0 + m[0][0] + m[1][1] + m[2][2])) / 2.0
    return ((m[2][1] - m[1][2]) / (4 * w), (m[0][2] - m[2][0]) / (4 * w), (m[1][0] - m[0][1]) / (4 * w), w)


class Camera:
    """`rgb()` (N, height, width, 3) uint8 on the sim device: what each env's camera sees now."""

    def __init__(self, cfg: CameraCfg, entity: Entity, model):
        import warp as wp
        from newton.sensors import SensorCamera

        ids, names = entity.find_bodies(cfg.body_name)
        if len(ids) != 1:
            raise ValueError(f"camera body_name '{cfg.body_name}' must match one body, matched {names}")
        if cfg.width < 1 or cfg.height < 1:
            raise ValueError(f"camera width and height must be >= 1 px, got {cfg.width} x {cfg.height}")
        self.cfg = cfg
        self.entity = entity
        self.body_id = ids[0]
        self.model = model
        device = entity.device
        n = entity.num_envs
        self.sensor = SensorCamera(model)
        self.sensor.create_default_light()
        self.rays = SensorCamera.compute_camera_rays_pinhole_opencv(
            cfg.width, cfg.height, cfg.fx, cfg.fy, cfg.cx, cfg.cy, image_width=float(cfg.calibration_size_px[0]),
            image_height=float(cfg.calibration_size_px[1]), device=model.device)
        self.offset_pos_b = torch.tensor(cfg.offset_pos_m, dtype=torch.float32, device=device).expand(n, 3)
        self.offset_quat = torch.tensor(optical_frame_quat_xyzw(cfg.pitch_down_rad), dtype=torch.float32,
                                        device=device).expand(n, 4)
        self.pose_w = torch.zeros(n, 7, dtype=torch.float32, device=device)
        """(N, 7) camera position [m] and orientation (xyzw) in the world, Newton's camera frame."""
        self._transforms = wp.from_torch(self.pose_w, dtype=wp.transformf)
        self._image = self.sensor.allocate_image_color(n, cfg.width, cfg.height)
        self._rgba = wp.to_torch(self._image).view(torch.uint8).view(n, cfg.height, cfg.width, 4)
        self._stale = True

    def mark_stale(self) -> None:
        """The state changed: the next `rgb()` renders again."""
        self._stale = True

    def set_light(self, direction_xyz, color_rgb) -> None:
        """The scene's one directional light (every world's), e.g. randomised by a recorder between frames."""
        import warp as wp

        self.sensor.create_default_light(direction=wp.vec3f(*direction_xyz), color=wp.vec3f(*color_rgb))
        self._stale = True

    def rgb(self, state) -> torch.Tensor:
        """(N, H, W, 3) uint8: each env's view of its own world in `state` (a view of the render buffer, valid until
        the next render)."""
        if self._stale:
            pose = self.entity.body_pose_w[:, self.body_id]
            self.pose_w[:, :3] = pose[:, :3] + quat_rotate(pose[:, 3:7], self.offset_pos_b)
            self.pose_w[:, 3:] = quat_mul(pose[:, 3:7], self.offset_quat)
            # the ray tracer culls by the shape bounds built at finalize: refit them to where the bodies are now
            self.model.bvh_refit_shapes(state)
            self.sensor.update(state, self._transforms, self.rays, color_image=self._image)
            self._stale = False
        return self._rgba[..., :3]
