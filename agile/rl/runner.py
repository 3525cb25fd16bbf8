"""The runner `agile train` trains with: rsl-rl's `OnPolicyRunner` (or `DistillationRunner`) with checkpoints written
whole or not at all, the env's training state and the run's overrides in every checkpoint, and a logger that does not
synchronise with the GPU at every env step."""

from __future__ import annotations

import os
import time

import torch
from rsl_rl.runners import DistillationRunner, OnPolicyRunner

from agile.rl.logger import SyncFreeLogger
from agile.rl.rsl_rl_adapter import CpuRanksRunnerMixin, rebuilt_logger
from agile.utils.heap import heap_frozen


class CheckpointingRunner(CpuRanksRunnerMixin, OnPolicyRunner):
    """rsl-rl's runner, with checkpoints written whole or not at all (a temporary file, then renamed) and holding
    the env's training state (`infos["env_state"]`, from the env's `training_state()` where it has one) and the
    config overrides the run was started with (`infos["overrides"]`: what `agile eval` and a resume compare their
    own against) and its wall time (`infos["wall_s"]`: seconds since the training started, those of the runs it
    continues included; `agile time_to_policy --resume` counts on from it), and a logger that does not synchronise
    with the GPU at every env step (`SyncFreeLogger`); CPU ranks train across processes too, with gloo
    (`CpuRanksRunnerMixin`)."""

    def __init__(self, *args, overrides: tuple[str, ...] | list[str] = (), started_at: float | None = None,
                 **kwargs):
        super().__init__(*args, **kwargs)
        self.started_at = time.time() if started_at is None else started_at
        """time.time() when this run started (its env build and kernel compilation count as training time)."""
        self.wall_s_before: float | None = 0.0
        """Seconds the runs this one continues trained (`continue_wall_time`); None: unknown (an older checkpoint)."""
        self.logger = rebuilt_logger(SyncFreeLogger, self)
        self.overrides = list(overrides)
        """The run's "env.<path>=<value>" and "agent.<path>=<value>" overrides, a recipe's included, in order."""

    def save(self, path: str, infos: dict | None = None) -> None:
        infos = dict(infos or {})
        env = getattr(self.env, "env", self.env)
        if hasattr(env, "training_state"):
            infos["env_state"] = env.training_state()
        infos["overrides"] = list(self.overrides)
        if self.wall_s_before is not None:
            infos["wall_s"] = round(self.wall_s_before + time.time() - self.started_at, 1)
        saved = self.alg.save()
        saved["iter"] = self.current_learning_iteration
        saved["infos"] = infos
        tmp_path = f"{path}.tmp"
        torch.save(saved, tmp_path)
        os.replace(tmp_path, path)
        self.logger.save_model(path, self.current_learning_iteration)

    def continue_wall_time(self, checkpoint: dict) -> None:
        """Count the wall time on from the checkpoint this run resumes (none recorded: the new checkpoints record
        none either, as the run's whole wall time is unknown)."""
        self.wall_s_before = (checkpoint.get("infos") or {}).get("wall_s")

    @heap_frozen()
    def learn(self, *args, **kwargs):
        """rsl-rl's `learn`, with what exists when it starts out of the garbage collector's whole-heap passes
        (`agile.utils.heap`: a pass over a simulator's process takes about a second)."""
        return super().learn(*args, **kwargs)


class CheckpointingDistillationRunner(CheckpointingRunner, DistillationRunner):
    """The same for distillation (rsl-rl's DistillationRunner refuses to learn before a teacher is loaded)."""


def training_runner(env, agent_cfg, log_dir: str | None, wrap=None, overrides=(),
                    started_at: float | None = None) -> CheckpointingRunner:
    """The runner `agile train` trains with (and `agile benchmark` times): the checkpointing runner of the agent
    config over `wrap(env, nan_check_every_steps)` (default `RslRlVecEnvWrapper`), rsl-rl's per-step NaN check moved
    into the wrapper (`defer_nan_check`), the config's matmul precision set for the process; `overrides`, the
    configs' overrides the run was built with, go into every checkpoint; `started_at` (time.time(), default now): when
    the run started, its checkpoints' wall time counting from it."""
    from agile.rl.configs import set_matmul_precision, to_rsl_rl_dict
    from agile.rl.vecenv_wrapper import RslRlVecEnvWrapper, defer_nan_check

    train_cfg = to_rsl_rl_dict(agent_cfg)
    wrapped = (wrap or RslRlVecEnvWrapper)(env, defer_nan_check(train_cfg))
    set_matmul_precision(agent_cfg)
    return runner_class(agent_cfg)(wrapped, train_cfg, log_dir=log_dir, device=str(env.device), overrides=overrides,
                                     started_at=started_at)


def runner_class(agent_cfg) -> type[CheckpointingRunner]:
    """The checkpointing runner for a PPO or a distillation agent config."""
    from agile.rl.configs import is_distillation

    return CheckpointingDistillationRunner if is_distillation(agent_cfg) else CheckpointingRunner
