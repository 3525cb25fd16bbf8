"""The browser viewer of a running env: Newton's viser viewer, framed on env 0, with live panels.

Newton's `ViewerViser` draws the model's shapes from the simulation state and brings Pause, Step and Reset;
this adds what a researcher watching an env needs: the camera on env 0's entities (and following them), the
reward terms of env 0 over the last steps, and the active commands. Everything here runs on the thread that
steps the env; viser's callbacks only set flags that the next frame reads.
"""

from __future__ import annotations

import math
import time

import numpy as np
import torch

from agile.gui.panels import CommandPanel, RewardPlot

LOCAL_HOST = "127.0.0.1"
CAMERA_PITCH_DEG = -12.0
CAMERA_YAW_DEG = 200.0
"""Looking back at the robots' fronts (they face +x) from slightly to their right."""
CLIENT_SETTLE_S = 1.0
"""How long a newly connected browser's camera is held on the framing of env 0: on connecting it also receives
Newton's stored camera, whose orbit point is not env 0."""


def camera_pose(target_m: np.ndarray, spread_m: float, pitch_deg: float = CAMERA_PITCH_DEG,
                yaw_deg: float = CAMERA_YAW_DEG) -> tuple[np.ndarray, float]:
    """(camera position [m], distance [m]) looking at `target_m` along the (pitch, yaw) direction, far enough
    to show a humanoid with a 45° field of view, plus the spread of several entities side by side."""
    distance = 2.6 + 1.2 * spread_m
    pitch, yaw = math.radians(pitch_deg), math.radians(yaw_deg)
    front = np.array([math.cos(yaw) * math.cos(pitch), math.sin(yaw) * math.cos(pitch), math.sin(pitch)])
    return target_m - front * distance, distance


class BrowserViewer:
    """Newton's viser viewer of `env`, listening on `host` (this machine only unless the user says), with
    the camera on env 0, a reward plot and the commands. Call `render(env)` after every env step."""

    def __init__(self, env, port: int, host: str = LOCAL_HOST, follow: bool = True):
        import newton.viewer

        if host not in (LOCAL_HOST, "localhost", "::1"):
            print(f"[agile] warning: the viewer listens on {host}:{port} without authentication: anyone who can "
                  f"reach that address watches the run and drives its controls")
        self.viewer = newton.viewer.ViewerViser(port=port, host=host, verbose=False)
        self.viewer.set_model(env.sim.model)
        # the worlds already sit at their env origins (a grid or terrain cells): no extra offsets
        self.viewer.set_world_offsets((0.0, 0.0, 0.0))
        self.server = self.viewer.server
        # the controls in a sidebar, not over the 3D view: the framed robots stay in the middle of what is seen
        self.server.gui.main_panel.dock_right()
        self.url = f"http://{'localhost' if host == LOCAL_HOST else host}:{port}"
        self.reset_requested = False
        self.viewer.set_reset_callback(self._request_reset)
        self._entities = [e for e in env.scene.entities.values() if getattr(e, "body_type", None) != "fixed"]
        self._framing_since: dict[int, float] = {}
        """When each browser was (re)framed on env 0 [s, monotonic clock]."""
        self._written_target: dict[int, np.ndarray] = {}
        """Env 0's position when each browser's camera was last written [m]."""
        with self.server.gui.add_folder("Camera", order=1.0):
            self.follow = self.server.gui.add_checkbox("Follow env 0", initial_value=follow)
            frame = self.server.gui.add_button("Frame env 0")
        frame.on_click(lambda _event: self._framing_since.clear())
        self.rewards = RewardPlot(self.server, env)
        self.commands = CommandPanel(self.server, env)
        self.frame_env0()

    def _request_reset(self) -> None:
        self.reset_requested = True

    def _env0_roots(self) -> np.ndarray:
        """(E, 3) root positions of env 0's entities (fixed objects like a table aside) [m], world frame."""
        return torch.stack([e.root_pos_w[0] for e in self._entities]).detach().cpu().numpy()

    @staticmethod
    def _framing_offset(roots: np.ndarray) -> np.ndarray:
        """Camera position relative to the entities' mean for a view of all of them [m]."""
        target = roots.mean(axis=0)
        position, _ = camera_pose(target, float(np.linalg.norm(roots.max(axis=0) - roots.min(axis=0))))
        return position - target

    def frame_env0(self) -> None:
        """Point every browser (those connected, and the next ones) at env 0's entities."""
        roots = self._env0_roots()
        position = roots.mean(axis=0) + self._framing_offset(roots)
        self.viewer.set_camera(tuple(position), pitch=CAMERA_PITCH_DEG, yaw=CAMERA_YAW_DEG)
        self._framing_since.clear()

    def _update_cameras(self) -> None:
        """Each browser looks at env 0: framed for a moment after it connects (or after "Frame env 0"), then,
        while "Follow env 0" is on, moved with env 0 keeping the user's orbit and zoom.

        Cameras are written whole (position, look-at point, up) from env 0's position and an offset, never
        by adding to what a browser last reported: reports arrive a frame or two late."""
        roots = self._env0_roots()
        target = roots.mean(axis=0)
        now = time.monotonic()
        for client_id, client in self.server.get_clients().items():
            since = self._framing_since.setdefault(client_id, now)
            if now - since < CLIENT_SETTLE_S:
                offset = self._framing_offset(roots)
            elif self.follow.value and np.abs(target - self._written_target.get(client_id, target)).max() > 1e-3:
                offset = client.camera.position - client.camera.look_at
            else:
                continue  # nothing moved: every write makes the browser draw again
            self._written_target[client_id] = target
            with client.atomic():  # position first: viser moves look_at with it, then look_at is set
                client.camera.position = target + offset
                client.camera.look_at = target
                client.camera.up_direction = (0.0, 0.0, 1.0)

    def should_step(self) -> bool:
        """False while the user has paused the run (Newton's Pause), True once per click on Step."""
        return self.viewer.should_step()

    def is_running(self) -> bool:
        return self.viewer.is_running()

    def render(self, env, time_s: float) -> None:
        """Draw the current state and refresh the camera and panels."""
        self.viewer.begin_frame(time_s)
        self.viewer.log_state(env.sim.state)
        self.viewer.end_frame()
        self._update_cameras()
        self.rewards.update(env)
        self.commands.update(env)

    def close(self) -> None:
        self.viewer.close()
        self.server.stop()
