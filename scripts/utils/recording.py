"""Recording a rollout as an animated USD stage (Newton's USD viewer, usd-core), for usdview or Omniverse."""

from __future__ import annotations


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
