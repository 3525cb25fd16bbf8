"""The commands `agile sim2mujoco` gives an exported policy in plain MuJoCo, from the IO descriptor's "commands" entry
(drawn as the training command term draws them, or fixed, or a height ramp), and the tracking errors measured
against them. One class per kind of command term: a velocity command (with or without a base height) and the
height command of HeightTracking-G1 (`SmoothHeightCommand`)."""

from __future__ import annotations

import math

import numpy as np

HEIGHT_COMMAND = "SmoothHeightCommand"
FINAL_WINDOW_S = 1.0
"""A height ramp's end: the tracked point's mean height over this last part of the episode."""


def make_commands(spec: dict, rng: np.random.Generator, control_dt_s: float, fixed=None, height_ramp=None):
    """The command source for the descriptor's command term `spec`; ValueError naming what does not fit."""
    if spec.get("type") == HEIGHT_COMMAND:
        return HeightCommands(spec, rng, control_dt_s, fixed, height_ramp)
    if height_ramp is not None:
        raise ValueError(f"--height_ramp is for a height command ({HEIGHT_COMMAND}); this policy's command is a "
                         f"{spec.get('type')}")
    return VelocityCommands(spec, rng, fixed)


class VelocityCommands:
    """(vx, vy, wz) uniform in the ranges, or for a velocity-and-height command (a `base_height_m` range) either
    standing still at a uniform height (a `rel_standing_envs` share) or walking at `default_height_m`; one per
    episode. Errors: planar velocity, yaw rate, and the root's height above the ground for a height command."""

    ends_at_a_fall = True

    def __init__(self, spec: dict, rng: np.random.Generator, fixed=None):
        self.ranges = spec["ranges"]
        self.params = spec.get("params", {})
        self.rng = rng
        self.has_height = "base_height_m" in self.ranges
        self.dim = 4 if self.has_height else 3
        self.lowest_height_m = self.ranges["base_height_m"][0] if self.has_height else math.inf
        if fixed is not None and len(fixed) != self.dim:
            raise ValueError(f"--command has {len(fixed)} values; the policy's command has {self.dim} "
                             f"(VX VY WZ{' HEIGHT' if self.has_height else ''})")
        self.fixed = fixed
        self.current = np.zeros(self.dim)
        self.lin_errors, self.ang_errors, self.height_errors = [], [], []

    def _draw(self) -> list[float]:
        velocity = [self.rng.uniform(*self.ranges[k]) for k in ("lin_vel_x", "lin_vel_y", "ang_vel_z")]
        if not self.has_height:
            return velocity
        if self.rng.uniform() < self.params.get("rel_standing_envs", 0.0):
            return [0.0, 0.0, 0.0, self.rng.uniform(*self.ranges["base_height_m"])]
        return [*velocity, self.params.get("default_height_m", self.ranges["base_height_m"][1])]

    def start_episode(self, steps: int) -> None:
        self.current = np.array(self.fixed if self.fixed is not None else self._draw(), dtype=np.float64)

    def command(self, step: int) -> np.ndarray:
        return self.current

    def measure(self, model, data, robot, step: int) -> None:
        v_b = robot.root_lin_vel_b(data)
        self.lin_errors.append(float(np.linalg.norm(self.current[:2] - v_b[:2])))
        self.ang_errors.append(float(abs(self.current[2] - data.qvel[5])))
        if self.has_height:  # the base height above the ground plane
            self.height_errors.append(float(abs(self.current[3] - data.qpos[2])))

    def metrics(self) -> dict:
        out = {"lin_vel_error_mps": float(np.mean(self.lin_errors)),
               "ang_vel_error_radps": float(np.mean(self.ang_errors))}
        if self.height_errors:
            out["base_height_error_m"] = float(np.mean(self.height_errors))
        return out


class HeightCommands:
    """The target height [m] above the ground of a point of the robot (`body_name` + `offset_b_m` in its frame).

    Drawn as in training: a new target every `resampling_time_range_s`, the top of the range (stand) with
    `standing_ratio`, the bottom (lie relaxed) with `flat_ratio`, else uniform; or fixed (`--command H`); or a ramp
    (`--height_ramp TOP BOTTOM`): TOP, down to BOTTOM at the episode's middle, back to TOP at its end, then held
    for the last second. Errors: |height - command| on the steps `settle_time_s` after a new target whose command
    is >= 0 (a negative command asks to lie relaxed, not for a height), as the env's `height_error_m`; for a ramp,
    every step with a command >= 0, and the point's mean height over the last second. Lying down is the task, so
    no fall ends an episode."""

    ends_at_a_fall = False
    lowest_height_m = -math.inf

    def __init__(self, spec: dict, rng: np.random.Generator, control_dt_s: float, fixed=None, ramp=None):
        params = spec.get("params", {})
        missing = [k for k in ("body_name", "offset_b_m") if k not in params]
        if missing:
            raise ValueError(f"the IO descriptor's height command lacks {missing}: export the policy again")
        self.body_name, self.offset_b = params["body_name"], np.asarray(params["offset_b_m"], dtype=np.float64)
        self.low, self.high = spec["ranges"]["height_m"]
        self.params, self.rng, self.dt = params, rng, control_dt_s
        if fixed is not None and len(fixed) != 1:
            raise ValueError(f"--command has {len(fixed)} values; the policy's command is one height [m]")
        self.fixed, self.ramp = fixed, ramp
        self.dim = 1
        self.settle_steps = int(params.get("settle_time_s", 0.0) / control_dt_s)
        self.schedule = np.zeros(0)
        self.changed_at = np.zeros(0, dtype=int)
        self.errors, self.final_heights = [], []
        self.body_id = None

    def _draw_target(self) -> float:
        u = self.rng.uniform()
        if u < self.params.get("standing_ratio", 0.0):
            return self.high
        if u < self.params.get("standing_ratio", 0.0) + self.params.get("flat_ratio", 0.0):
            return self.low
        return self.rng.uniform(self.low, self.high)

    def start_episode(self, steps: int) -> None:
        t = np.arange(steps) * self.dt
        if self.ramp is not None:
            top, bottom = self.ramp
            ramp_s = max(steps * self.dt - FINAL_WINDOW_S, self.dt)
            phase = np.clip(t / ramp_s, 0.0, 1.0)
            self.schedule = top + (bottom - top) * (1.0 - np.abs(2.0 * phase - 1.0))
            self.changed_at = np.zeros(steps, dtype=int)
            return
        if self.fixed is not None:
            self.schedule = np.full(steps, float(self.fixed[0]))
            self.changed_at = np.zeros(steps, dtype=int)
            return
        self.schedule, self.changed_at = np.zeros(steps), np.zeros(steps, dtype=int)
        low_s, high_s = self.params.get("resampling_time_range_s", (1.0, 7.0))
        step = 0
        while step < steps:
            length = max(1, int(round(self.rng.uniform(low_s, high_s) / self.dt)))
            self.schedule[step:step + length] = self._draw_target()
            self.changed_at[step:step + length] = step
            step += length

    def command(self, step: int) -> np.ndarray:
        return np.array([self.schedule[step]])

    def tracked_height_m(self, model, data) -> float:
        import mujoco

        if self.body_id is None:
            self.body_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, self.body_name)
            if self.body_id < 0:
                raise ValueError(f"the height command's body '{self.body_name}' is not in the MuJoCo model")
        rotation = data.xmat[self.body_id].reshape(3, 3)
        return float(data.xpos[self.body_id][2] + (rotation @ self.offset_b)[2])

    def measure(self, model, data, robot, step: int) -> None:
        height = self.tracked_height_m(model, data)
        target = self.schedule[step]
        settled = self.ramp is not None or step - self.changed_at[step] >= self.settle_steps
        if target >= 0.0 and settled:
            self.errors.append(abs(height - target))
        if self.ramp is not None and step >= len(self.schedule) - int(round(FINAL_WINDOW_S / self.dt)):
            self.final_heights.append(height)

    def metrics(self) -> dict:
        out = {"height_error_m": float(np.mean(self.errors)) if self.errors else None}
        if self.ramp is not None:
            final = float(np.mean(self.final_heights))
            out.update(final_height_m=final, final_height_error_m=abs(final - self.ramp[0]))
        return out
