"""How long an iteration takes, said at the first env step of a training run: on a CPU an iteration of thousands of
envs takes minutes, and the first progress line of the runner comes only after it."""

from __future__ import annotations

import time

from agile.rl.vecenv_wrapper import RslRlVecEnvWrapper


class FirstStepTimingVecEnv(RslRlVecEnvWrapper):
    """The training wrapper, which times its first step and prints what an iteration's rollout of
    `steps_per_iteration` steps will take at that rate (the first step includes one-time work: an upper bound)."""

    def __init__(self, env, nan_check_every_steps: int = 0, *, steps_per_iteration: int):
        super().__init__(env, nan_check_every_steps)
        self.steps_per_iteration = steps_per_iteration
        self.first_step_s = None

    def step(self, actions):
        if self.first_step_s is not None:
            return super().step(actions)
        start = time.perf_counter()
        result = super().step(actions)
        self.first_step_s = time.perf_counter() - start
        print(f"[agile] the first env step took {self.first_step_s:.2f} s ({self.num_envs} envs on {self.device}): "
              f"an iteration's {self.steps_per_iteration} steps take up to "
              f"{self.first_step_s * self.steps_per_iteration:.0f} s before its update", flush=True)
        return result
