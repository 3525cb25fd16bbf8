"""Training progress as one line with an ETA (tqdm) instead of rsl-rl's 40-line block every iteration.

rsl-rl's `Logger.log` writes tensorboard scalars and prints a block per iteration. `ProgressLogger` keeps
everything it writes and shows a bar instead: iterations done of the run's, the rate, the time left, and the mean
reward and episode length; rsl-rl's full block still appears every `full_log_every` iterations (0: never), above
the bar.
"""

from __future__ import annotations

import contextlib
import io
import statistics

from rsl_rl.utils.logger import Logger
from tqdm import tqdm

PROGRESS_MODES = ("auto", "bar", "log")
"""bar: the progress line; log: rsl-rl's block every iteration (log files); auto: bar on a terminal, else log."""


class ProgressLogger(Logger):
    """rsl-rl's logger with a progress bar; built from the runner's own logger (`from_logger`)."""

    full_log_every: int = 100
    total_iterations: int | None = None
    """The bar's length: the whole run's iterations, where it is learned in several `learn` calls (video clips)."""
    bar: tqdm | None = None

    @classmethod
    def from_logger(cls, logger: Logger, runner, full_log_every: int,
                    total_iterations: int | None = None) -> ProgressLogger:
        """The same logger (log dir, config, buffers) showing a bar: built with the arguments the runner gave its
        own, before training starts (rsl-rl creates the tensorboard writer in `learn`). Without
        `total_iterations`, the bar is as long as the first `learn` call."""
        progress = cls(log_dir=logger.log_dir, cfg=logger.cfg, env_cfg=logger.env_cfg, num_envs=logger.num_envs,
                       is_distributed=runner.is_distributed, gpu_world_size=runner.gpu_world_size,
                       gpu_global_rank=runner.gpu_global_rank, device=logger.device)
        progress.git_status_repos = logger.git_status_repos
        progress.full_log_every = full_log_every
        progress.total_iterations = total_iterations
        return progress

    def log(self, **kwargs) -> None:
        block = io.StringIO()
        with contextlib.redirect_stdout(block):
            super().log(**kwargs)
        if self.writer is None:  # another GPU's process of a multi-GPU run: rank 0 shows the progress
            return
        it = kwargs["it"]
        if self.bar is None:
            total = self.total_iterations or kwargs["total_it"] - kwargs["start_it"]
            self.bar = tqdm(total=total, unit="it", desc="training", dynamic_ncols=True)
        if self.full_log_every and (self.bar.n + 1) % self.full_log_every == 0:
            self.bar.write(block.getvalue())
        postfix = {"iteration": it}
        if self.rewbuffer:
            postfix["reward"] = f"{statistics.mean(self.rewbuffer):.2f}"
            postfix["episode"] = f"{statistics.mean(self.lenbuffer):.0f} steps"
        self.bar.set_postfix(postfix, refresh=False)
        self.bar.update(1)
        if self.bar.n >= self.bar.total:
            self.bar.close()


def show_progress(runner, mode: str, full_log_every: int, is_terminal: bool, total_iterations: int) -> None:
    """Give the runner a progress bar over `total_iterations` where `mode` asks for one ('auto': when output goes
    to a terminal)."""
    if mode not in PROGRESS_MODES:
        raise ValueError(f"progress mode '{mode}': choose one of {PROGRESS_MODES}")
    if mode == "bar" or (mode == "auto" and is_terminal):
        runner.logger = ProgressLogger.from_logger(runner.logger, runner, full_log_every, total_iterations)
