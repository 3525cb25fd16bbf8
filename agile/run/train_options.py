"""What an `agile train` run is started with (`TrainOptions`) and what it leaves (`TrainResult`), apart from the
command so that the modules that start and run a training read them without importing it."""

from __future__ import annotations

import dataclasses
import os

DEFAULT_LOG_ROOT = os.path.join("logs", "rsl_rl")


@dataclasses.dataclass(frozen=True)
class TrainOptions:
    """Everything a training run is started with (`train`'s keyword arguments; see them for each field)."""
    task: str
    num_envs: int | None = None
    device: str | None = None
    seed: int | None = None
    rnn: str | None = None
    overrides: tuple = ()
    max_iterations: int | None = None
    resume: bool = False
    checkpoint: str | None = None
    init_policy: tuple = ()
    init_action_std: float | None = None
    logger: str | None = None
    run_name: str | None = None
    log_root: str = DEFAULT_LOG_ROOT
    video: bool = False
    video_interval: int = 500
    video_length: int = 200
    inject_nan_actions: tuple | None = None
    progress: str = "auto"
    full_log_every: int = 100
    teacher: str | None = None
    distributed: bool = False
    trust_checkpoint: bool = False
    collect_datasets_anew: bool = False
    trainer: str = "rsl_rl"


@dataclasses.dataclass(frozen=True)
class TrainResult:
    """What a training run leaves: its folder (None on a distributed run's other ranks), the last checkpoint and the
    exported policy files ({kind: path}; a multi-agent run: {"groups": the folder of a subfolder per group})."""
    log_dir: str | None
    checkpoint: str | None
    exported: dict
