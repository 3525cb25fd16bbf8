"""Recording a rollout as an animated USD stage (Newton's USD viewer, usd-core), for usdview or Omniverse."""

from __future__ import annotations

DEFAULT_CAMERA_OFFSET_M = (1.8, -1.8, 0.7)
"""A video camera from the point it follows [m], world frame: ahead of a robot (robots face +x) and to its right."""


class UsdRecorder:
    """One time sample per env step, of the first `max_worlds` worlds (their colliders: visual meshes are
    not loaded for simulation)."""

    def __init__(self, path: str, env, num_frames: int, max_worlds: int = 4):
        import newton.viewer

        self.viewer = newton.viewer.ViewerUSD(path, fps=round(1.0 / env.step_dt), num_frames=num_frames)
        self.viewer.set_model(env.sim.model)
        self.viewer.set_visible_worlds(range(min(max_worlds, env.num_envs)))
        self.path = path

    def record(self, env, time_s: float) -> None:
        self.viewer.begin_frame(time_s)
        self.viewer.log_state(env.sim.state)
        self.viewer.end_frame()

    def close(self) -> None:
        self.viewer.close()


def _look_at_quat_xyzw(eye, target):
    """Rotation of a camera at `eye` looking at `target` (camera x right, y up, looking along -z), z up."""
    import numpy as np

    forward = np.asarray(target, dtype=float) - np.asarray(eye, dtype=float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    m = np.stack([right, up, -forward], axis=1)
    w = np.sqrt(max(1e-12, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    return ((m[2, 1] - m[1, 2]) / (4 * w), (m[0, 2] - m[2, 0]) / (4 * w), (m[1, 0] - m[0, 1]) / (4 * w), w)


class CameraVideo:
    """An mp4 of one world of a Newton model, rendered headless by Newton's Warp ray-tracing camera, which
    follows a point (the robot's root)."""

    def __init__(self, path: str, model, fps: int, width: int = 640, height: int = 480, world_index: int = 0,
                 camera_offset_m: tuple[float, float, float] = DEFAULT_CAMERA_OFFSET_M):
        import imageio.v2 as imageio
        import warp as wp
        from newton.sensors import SensorCamera

        self.model = model
        self.camera = SensorCamera(model)
        self.camera.create_default_light()
        self.rays = SensorCamera.compute_camera_rays_pinhole(width, height, camera_fov=0.9, device=model.device)
        self.transforms = wp.array([wp.transform_identity()], dtype=wp.transformf, device=model.device)
        self.image = self.camera.allocate_image_color(1, width, height)
        self.size = (height, width)
        self.world_index = world_index
        self.writer = imageio.get_writer(path, fps=fps, macro_block_size=1)
        self.path = path
        self.frames = 0
        self.camera_offset_m = camera_offset_m
        """Where the camera stands from the followed point [m], world frame."""

    def write_frame(self, state, follow_pos_m, distance_scale: float = 1.0) -> None:
        import numpy as np
        import warp as wp

        eye = np.asarray(follow_pos_m, dtype=float) + np.asarray(self.camera_offset_m) * distance_scale
        target = np.asarray(follow_pos_m, dtype=float) - np.array([0.0, 0.0, 0.2])
        pose = wp.transformf(wp.vec3f(*eye), wp.quatf(*_look_at_quat_xyzw(eye, target)))
        self.transforms.assign(wp.array([pose], dtype=wp.transformf, device=self.transforms.device))
        # the ray tracer culls by the shape BVH built at finalize: without a refit a robot that has walked away
        # from its spawn pose is culled and the frame shows only the ground
        self.model.bvh_refit_shapes(state)
        self.camera.update(state, self.transforms, self.rays, color_image=self.image)
        frame = self.image.numpy()[self.world_index].view(np.uint8).reshape(*self.size, 4)[..., :3]
        self.writer.append_data(frame)
        self.frames += 1

    def close(self) -> None:
        self.writer.close()


class VideoRecorder(CameraVideo):
    """An mp4 of one env of a ManagerBasedRLEnv (following its policy's robot) or of a MultiAgentEnv (framing all
    its robots: the camera follows their centre and backs off as they spread), one frame per step.

    reference=True (a task whose command has a whole-body reference pose, e.g. motion tracking): the frame also
    shows an orange kinematic copy of the robot at the command's reference pose, about 1 m to the robot's right
    as the camera sees it (`reference_view.ReferenceScene`), and the camera frames both."""

    def __init__(self, path: str, env, width: int = 640, height: int = 480, env_index: int = 0,
                 reference: bool = False):
        multi_agent = hasattr(env, "agents")
        step_dt = env.mean_slot_dt_s if multi_agent else env.step_dt
        self.reference = None
        if reference:
            from agile.run.reference_view import ReferenceScene

            self.reference = ReferenceScene(env, env_index)
        # the reference scene holds only the recorded env's world, as its world 0
        model, world = (env.sim.model, env_index) if self.reference is None else (self.reference.model, 0)
        offset = (None if multi_agent else env.cfg.video_camera_offset_m) or DEFAULT_CAMERA_OFFSET_M
        super().__init__(path, model, round(1.0 / step_dt), width, height, world, tuple(offset))
        self.env_index = env_index
        self.robots = sorted(env.scene.articulations) if multi_agent else [env.action_manager.policy_entity_name()]

    def record(self, env, time_s: float | None = None) -> None:
        import numpy as np

        roots = [env.scene[r].root_pos_w[self.env_index].detach().cpu().numpy() for r in self.robots]
        state = env.sim.state
        if self.reference is not None:
            self.reference.update(env)
            roots.append(self.reference.reference_root_pos_w(env).detach().cpu().numpy())
            state = self.reference.state
        roots = np.stack(roots)
        centre = roots.mean(axis=0)
        spread_m = float(np.linalg.norm(roots[:, :2] - centre[:2], axis=1).max())
        self.write_frame(state, centre, distance_scale=1.0 + spread_m / 1.5)
