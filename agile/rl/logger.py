"""rsl-rl's training logger without a host synchronisation at every env step.

rsl-rl's `Logger.process_env_step` finds the episodes that just ended with `nonzero` and copies their returns and
lengths to the host, every env step: the host waits for the GPU to finish that step before it may launch the
policy's next inference, so the GPU idles while Python launches the policy's and the storage's small kernels (a
rollout's host launches are otherwise hidden behind the previous env step's graph). `SyncFreeLogger` writes each
step's finished episodes into device buffers (one row per step of the rollout) and moves them to the host once per
iteration, when it logs: the same returns and lengths, in the same order (step by step, env by env), in the same
100-episode windows (`rewbuffer`, `lenbuffer`) that rsl-rl's report and tensorboard read. The episode extras
(`extras["log"]`) are averaged over the rollout in one reduction before rsl-rl's `log` reads them.

It also keeps the host's clock at each iteration's log (`iteration_stamps_s`, the last `STAMPS_KEPT`): the wall
time between two is one whole iteration of the runner (rollout, update, log, any checkpoint save), which
`agile benchmark` reads to time training iteration by iteration.

The training runners (`CheckpointingRunner`) use it, and the progress loggers (`agile.rl.progress`)
build on it. With RND's intrinsic rewards it keeps rsl-rl's per-step bookkeeping (none of our tasks uses RND).
"""

from __future__ import annotations

import collections
import time

import torch
from rsl_rl.utils.logger import Logger

from agile.rl.rsl_rl_adapter import logger_gathering_on_host


STAMPS_KEPT = 1000
"""Iteration stamps a logger keeps (a benchmark reads tens; a training of 100,000 iterations stays bounded)."""


class SyncFreeLogger(Logger):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.iteration_stamps_s: collections.deque[tuple[int, float]] = collections.deque(maxlen=STAMPS_KEPT)
        """(iteration, `time.perf_counter()` when its log began), the newest last."""
        rows = max(1, int(self.cfg.get("num_steps_per_env", 1)))  # a rollout's steps: one flush per iteration
        self.ended = torch.zeros(rows, self.num_envs, dtype=torch.bool, device=self.device)
        """(steps, N): which envs' episodes ended at each step held since the last flush."""
        self.ended_return = torch.zeros(rows, self.num_envs, device=self.device)
        """(steps, N): the return summed up to each step (read where `ended`)."""
        self.ended_length_steps = torch.zeros(rows, self.num_envs, device=self.device)
        self.steps_held = 0

    def process_env_step(self, rewards: torch.Tensor, dones: torch.Tensor, extras: dict,
                         intrinsic_rewards: torch.Tensor | None = None) -> None:
        if self.writer is None or intrinsic_rewards is not None:
            super().process_env_step(rewards, dones, extras, intrinsic_rewards)
            return
        if "episode" in extras:
            self.ep_extras.append(extras["episode"])
        elif "log" in extras:
            self.ep_extras.append(extras["log"])
        self.cur_reward_sum += rewards
        self.cur_episode_length += 1
        if self.steps_held == len(self.ended):  # more steps than a rollout's before a log (a longer loop)
            self.flush_ended_episodes()
        row, ended = self.steps_held, dones > 0
        self.ended[row] = ended
        self.ended_return[row] = self.cur_reward_sum
        self.ended_length_steps[row] = self.cur_episode_length
        self.cur_reward_sum.masked_fill_(ended, 0.0)
        self.cur_episode_length.masked_fill_(ended, 0.0)
        self.steps_held += 1

    def flush_ended_episodes(self) -> None:
        """Move the held steps' ended episodes into rsl-rl's windows (one host synchronisation)."""
        if self.steps_held == 0:
            return
        ended = self.ended[:self.steps_held]
        self.rewbuffer.extend(self.ended_return[:self.steps_held][ended].tolist())
        self.lenbuffer.extend(self.ended_length_steps[:self.steps_held][ended].tolist())
        self.steps_held = 0

    def average_episode_extras(self) -> bool:
        """Replace the held steps' extras by their means over the steps, on the host, where every step holds the same
        keys as 0-d tensors (the env's `extras["log"]`): rsl-rl's `log` then averages one value per key, the same
        means, instead of concatenating every step's value of every key one small op at a time (58 keys x 24 steps
        for G1: ~3,000 launches an iteration) and reading each key's mean back with two synchronisations (for
        tensorboard and for the console). The means come to the host in one copy. Whether it replaced them."""
        extras = self.ep_extras
        if not extras:
            return False
        keys = list(extras[0])
        scalar_tensors = all(isinstance(value, torch.Tensor) and value.dim() == 0 for value in extras[0].values())
        if not keys or not scalar_tensors or any(list(step) != keys for step in extras):
            return False
        per_step = torch.stack([torch.stack([value.float() for value in step.values()]) for step in extras])
        self.ep_extras = [dict(zip(keys, per_step.mean(dim=0).cpu().unsqueeze(1)))]
        return True

    def stop_logging_writer(self) -> None:
        """rsl-rl's, and the tensorboard writer closed too (rsl-rl stops only its own `LogWriter` kinds): the event
        file flushed and its writer thread ended at the end of every `learn`, not left to the interpreter's exit (a
        runner that learns again opens a new one)."""
        super().stop_logging_writer()
        from torch.utils.tensorboard import SummaryWriter

        if isinstance(self.writer, SummaryWriter):
            self.writer.close()

    def log(self, **kwargs) -> None:
        self.iteration_stamps_s.append((kwargs["it"], time.perf_counter()))
        self.flush_ended_episodes()
        if self.writer is None or not self.average_episode_extras():
            super().log(**kwargs)
            return
        # the extras are on the host now, so rsl-rl's log gathers them there. The action std is read twice: once.
        if isinstance(kwargs.get("action_std"), torch.Tensor):
            kwargs["action_std"] = kwargs["action_std"].mean().cpu()
        with logger_gathering_on_host(self):
            super().log(**kwargs)
