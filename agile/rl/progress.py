"""Training progress as one line with an ETA (tqdm) instead of rsl-rl's 40-line block every iteration.

rsl-rl's `Logger.log` writes tensorboard scalars and prints a block per iteration. Both loggers here build on
`SyncFreeLogger` (no host synchronisation per env step). `ProgressLogger` keeps
everything it writes and shows a bar instead: iterations done of the run's, the rate, the time left, and the mean
reward and episode length; rsl-rl's full block still appears every `full_log_every` iterations (0: never), above
the bar.
"""

from __future__ import annotations

import contextlib
import io
import re
import statistics

from tqdm import tqdm

from agile.rl.logger import SyncFreeLogger
from agile.rl.rsl_rl_adapter import rebuilt_logger

PROGRESS_MODES = ("auto", "bar", "log")
"""bar: the progress line; log: rsl-rl's block every iteration (log files); auto: bar on a terminal, else log."""
ANSI_ESCAPE = re.compile(r"\x1b\[[0-9;]*m")
"""Terminal escape codes (rsl-rl prints its block's title in bold), noise in a log file."""


class PlainLogger(SyncFreeLogger):
    """rsl-rl's logger printing its block without terminal escape codes: for output redirected to a file."""

    def log(self, **kwargs) -> None:
        block = io.StringIO()
        with contextlib.redirect_stdout(block):
            super().log(**kwargs)
        if block.getvalue():
            print(ANSI_ESCAPE.sub("", block.getvalue()), end="", flush=True)


class ProgressLogger(SyncFreeLogger):
    """rsl-rl's logger with a progress bar; built from the runner's own logger (`from_runner`)."""

    full_log_every: int = 100
    total_iterations: int | None = None
    """The bar's length: the whole run's iterations, where it is learned in several `learn` calls (video clips)."""
    bar: tqdm | None = None

    @classmethod
    def from_runner(cls, runner, full_log_every: int, total_iterations: int | None = None) -> ProgressLogger:
        """The same logger (`rebuilt_logger`) showing a bar. Without `total_iterations`, the bar is as long as the
        first `learn` call."""
        progress = rebuilt_logger(cls, runner)
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
    to a terminal), else rsl-rl's block every iteration, without escape codes where output goes to a file."""
    if mode not in PROGRESS_MODES:
        raise ValueError(f"progress mode '{mode}': choose one of {PROGRESS_MODES}")
    if mode == "bar" or (mode == "auto" and is_terminal):
        runner.logger = ProgressLogger.from_runner(runner, full_log_every, total_iterations)
    elif not is_terminal:
        runner.logger = rebuilt_logger(PlainLogger, runner)
