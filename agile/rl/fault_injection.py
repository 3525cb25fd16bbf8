"""Fault injection for reliability runs: NaN actions, as a diverged policy would send them.

`NanActionVecEnv` is the training wrapper with one addition: at the first step of every `every_iterations`-th
iteration it replaces the actions of a `share` of the envs (drawn anew each time) by NaN. The env must then
replace them, end those envs' episodes and count them (`Episode_Termination/invalid_action` in the log), and
training must go on with finite numbers. `scripts/train.py --inject_nan_actions SHARE EVERY` uses it.
"""

from __future__ import annotations

import torch

from agile.rl.vecenv_wrapper import RslRlVecEnvWrapper


class NanActionVecEnv(RslRlVecEnvWrapper):
    def __init__(self, env, nan_check_every_steps: int = 0, *, share: float, every_iterations: int,
                 steps_per_iteration: int):
        super().__init__(env, nan_check_every_steps)
        if not 0.0 < share <= 1.0:
            raise ValueError(f"NaN action share must be within (0, 1], got {share}")
        if every_iterations < 1:
            raise ValueError(f"NaN actions every {every_iterations} iterations: must be >= 1")
        self.num_faulty_envs = max(1, round(share * self.num_envs))
        self.period_steps = every_iterations * steps_per_iteration
        self.steps_per_iteration = steps_per_iteration
        self.steps_taken = 0
        self.injections = 0

    def step(self, actions: torch.Tensor):
        if self.steps_taken > 0 and self.steps_taken % self.period_steps == 0:
            faulty = torch.randperm(self.num_envs, device=actions.device)[:self.num_faulty_envs]
            actions = actions.clone()
            actions[faulty] = float("nan")
            self.injections += 1
            print(f"[agile] fault injection {self.injections}: NaN actions in {self.num_faulty_envs} envs "
                  f"({self.steps_taken // self.steps_per_iteration} iterations into this run)", flush=True)
        self.steps_taken += 1
        return super().step(actions)
