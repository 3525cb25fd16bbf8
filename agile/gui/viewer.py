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
CLIENT_SETTLE_S = 0.5
"""A newly connected browser receives Newton's stored camera when it connects; the orbit pivot is moved onto
env 0 this long after, once that has arrived."""


def camera_pose(target_m: np.ndarray, spread_m: float, pitch_deg: float = CAMERA_PITCH_DEG,
                yaw_deg: float = CAMERA_YAW_DEG) -> tuple[np.ndarray, float]:
    """(camera position [m], distance [m]) looking at `target_m` along the (pitch, yaw) direction, far enough
    to show a humanoid with a 45° field of view, plus the spread of several entities side by side."""
    distance = 2.2 + 1.2 * spread_m
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
        self.url = f"http://{'localhost' if host == LOCAL_HOST else host}:{port}"
        self.reset_requested = False
        self.viewer.set_reset_callback(self._request_reset)
        self._entities = [e for e in env.scene.entities.values() if not getattr(e, "body_type", "") == "fixed"]
        self._target_m = self._env0_target()
        self._client_seen_s: dict[int, float] = {}
        self._framed_clients: set[int] = set()
        with self.server.gui.add_folder("Camera", order=1.0):
            self.follow = self.server.gui.add_checkbox("Follow env 0", initial_value=follow)
            frame = self.server.gui.add_button("Frame env 0")
        frame.on_click(lambda _event: self._framed_clients.clear())
        self.rewards = RewardPlot(self.server, env)
        self.commands = CommandPanel(self.server, env)
        self.frame_env0()

    def _request_reset(self) -> None:
        self.reset_requested = True

    def _env0_target(self) -> np.ndarray:
        """Mean root position of env 0's entities (fixed objects like a table aside) [m], world frame."""
        roots = torch.stack([e.root_pos_w[0] for e in self._entities]).detach().cpu().numpy()
        return roots.mean(axis=0)

    def _env0_spread_m(self) -> float:
        roots = torch.stack([e.root_pos_w[0] for e in self._entities]).detach().cpu().numpy()
        return float(np.linalg.norm(roots.max(axis=0) - roots.min(axis=0)))

    def frame_env0(self) -> None:
        """Point every browser (and the ones that connect later) at env 0's entities."""
        position, _ = camera_pose(self._target_m, self._env0_spread_m())
        self.viewer.set_camera(tuple(position), pitch=CAMERA_PITCH_DEG, yaw=CAMERA_YAW_DEG)
        self._framed_clients.clear()

    def _frame_new_clients(self) -> None:
        """Put each browser's orbit pivot on env 0 (Newton's camera sets the view direction only), once."""
        now = time.monotonic()
        position, _ = camera_pose(self._target_m, self._env0_spread_m())
        for client_id, client in self.server.get_clients().items():
            if client_id in self._framed_clients:
                continue
            seen = self._client_seen_s.setdefault(client_id, now)
            if now - seen < CLIENT_SETTLE_S:
                continue
            with client.atomic():
                client.camera.position = position
                client.camera.look_at = self._target_m
                client.camera.up_direction = (0.0, 0.0, 1.0)
            self._framed_clients.add(client_id)

    def _follow(self) -> None:
        """Move every framed browser's camera with env 0's entities, keeping the user's orbit and zoom."""
        target = self._env0_target()
        delta = target - self._target_m
        self._target_m = target
        if not self.follow.value or not np.any(np.abs(delta) > 1e-4):
            return
        for client_id, client in self.server.get_clients().items():
            if client_id in self._framed_clients:
                with client.atomic():
                    client.camera.position = client.camera.position + delta
                    client.camera.look_at = client.camera.look_at + delta

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
        self._follow()
        self._frame_new_clients()
        self.rewards.update(env)
        self.commands.update(env)

    def close(self) -> None:
        self.viewer.close()
        self.server.stop()
