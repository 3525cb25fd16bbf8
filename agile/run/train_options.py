"""What an `agile train` run is started with (`TrainOptions`) and what it leaves (`TrainResult`), apart from the
command so that the modules that start and run a training read them without importing it; and the command lines
that start a training (or another module) as processes of their own, one or several ranks (`training_command`,
`torchrun_command`), for the commands that time trainings."""

from __future__ import annotations

import dataclasses
import os
import sys

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
    started_at: float | None = None
    """time.time() when `train` was called: the checkpoints' wall time counts from there, so that the simulator's and
    torch's imports (13-19 s on a GPU host), the env build and the kernel compilation are in it."""


@dataclasses.dataclass(frozen=True)
class TrainResult:
    """What a training run leaves: its folder (None on a distributed run's other ranks), the last checkpoint and the
    exported policy files ({kind: path}; a multi-agent run: {"groups": the folder of a subfolder per group})."""
    log_dir: str | None
    checkpoint: str | None
    exported: dict


def torchrun_command(module: str, args: list[str], ranks: int) -> list[str]:
    """`python -m module args` as `ranks` processes of this host (torchrun, standalone rendezvous)."""
    return [sys.executable, "-m", "torch.distributed.run", "--standalone", f"--nproc_per_node={ranks}", "-m", module,
            *args]


def training_command(train_args: list[str], gpus: int, device: str) -> list[str]:
    """`agile train train_args` as a process of its own: on `device`, or as `gpus` ranks under torchrun on the host's
    first GPUs (CPU ranks on gloo where `device` is "cpu")."""
    if gpus == 1:
        return [sys.executable, "-m", "agile.run.train", *train_args, "--device", device]
    cpu_ranks = ["--device", "cpu"] if device == "cpu" else []
    return torchrun_command("agile.run.train", [*train_args, "--distributed", *cpu_ranks], gpus)
