"""Loading checkpoints without running their code.

`torch.load(weights_only=False)` unpickles arbitrary objects, so a checkpoint from a paper's page or a
colleague can run code on the machine that plays, evaluates, exports or resumes it. Our checkpoints (RSL-RL's:
state dicts, the optimizer's state, the iteration, `infos`) hold only tensors and plain containers, which
`weights_only=True` loads. A file that needs more is refused, naming the type, unless the user trusts it
(`--trust_checkpoint`).
"""

from __future__ import annotations

import os
import pickle
import re

import torch
from rsl_rl.runners import DistillationRunner, OnPolicyRunner

from agile.rl_env.rsl_rl.sync_free_logger import SyncFreeLogger, rebuilt_logger
from agile.utils.heap import heap_frozen

TRUST_FLAG = "--trust_checkpoint"


class UntrustedCheckpointError(RuntimeError):
    """A checkpoint holds objects that only a full (code-running) unpickling can load."""


class UnreadableCheckpointError(RuntimeError):
    """A checkpoint file that torch cannot read at all: cut short (a crash while writing, a copy broken off),
    empty, or not a checkpoint."""


def load_checkpoint(path: str, map_location: str | torch.device = "cpu", trust: bool = False) -> dict:
    """The checkpoint's contents. Without `trust`, only tensors and plain containers are unpickled; a file that
    holds anything else raises UntrustedCheckpointError naming the type (and nothing of it runs). A file torch
    cannot read raises UnreadableCheckpointError naming it and torch's reason."""
    try:
        if trust:
            return torch.load(path, map_location=map_location, weights_only=False)
        return torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as err:
        if trust or "GLOBAL" not in str(err) and "Weights only load failed" not in str(err):
            raise UnreadableCheckpointError(_unreadable(path, err)) from None
        found = re.search(r"GLOBAL ([\w.]+)", str(err))
        what = f"an object of type '{found.group(1)}'" if found else "objects other than tensors and containers"
        raise UntrustedCheckpointError(
            f"checkpoint '{path}' holds {what}, which loading would have to run code for; refused. If you trust "
            f"where the file comes from, load it with {TRUST_FLAG}.") from None
    except (RuntimeError, EOFError, ValueError, OSError) as err:  # a zip archive cut short fails in many ways
        if isinstance(err, FileNotFoundError):
            raise
        raise UnreadableCheckpointError(_unreadable(path, err)) from None


def _unreadable(path: str, err: Exception) -> str:
    # torch's first sentence (it goes on with advice for its own users)
    reason = str(err).strip().splitlines()[0].split(". ")[0] if str(err).strip() else type(err).__name__
    size = os.path.getsize(path) if os.path.exists(path) else 0
    return (f"checkpoint '{path}' cannot be read ({size:,} bytes; {reason}): it was cut short (a crash while "
            f"writing, a copy broken off) or is not a checkpoint")


def restore_runner(runner, checkpoint: dict, load_cfg: dict | None = None, strict: bool = True) -> None:
    """What rsl-rl's `OnPolicyRunner.load(path)` does, from contents loaded by `load_checkpoint` (its own
    `load` unpickles with weights_only=False); the runner continues at the iteration after the checkpoint's
    (rsl-rl's own `load` would repeat it)."""
    if runner.alg.load(checkpoint, load_cfg, strict):
        runner.current_learning_iteration = checkpoint["iter"] + 1


class CheckpointingRunner(OnPolicyRunner):
    """rsl-rl's runner, with checkpoints written whole or not at all (a temporary file, then renamed) and holding
    the env's training state (`infos["env_state"]`, from the env's `training_state()` where it has one) and the
    config overrides the run was started with (`infos["overrides"]`: what `agile eval` and a resume compare their
    own against), and a logger that does not synchronise with the GPU at every env step (`SyncFreeLogger`)."""

    def __init__(self, *args, overrides: tuple[str, ...] | list[str] = (), **kwargs):
        super().__init__(*args, **kwargs)
        self.logger = rebuilt_logger(SyncFreeLogger, self.logger, self)
        self.overrides = list(overrides)
        """The run's "env.<path>=<value>" and "agent.<path>=<value>" overrides, a recipe's included, in order."""

    def save(self, path: str, infos: dict | None = None) -> None:
        infos = dict(infos or {})
        env = getattr(self.env, "env", self.env)
        if hasattr(env, "training_state"):
            infos["env_state"] = env.training_state()
        infos["overrides"] = list(self.overrides)
        saved = self.alg.save()
        saved["iter"] = self.current_learning_iteration
        saved["infos"] = infos
        tmp_path = f"{path}.tmp"
        torch.save(saved, tmp_path)
        os.replace(tmp_path, path)
        self.logger.save_model(path, self.current_learning_iteration)

    @heap_frozen()
    def learn(self, *args, **kwargs):
        """rsl-rl's `learn`, with what exists when it starts out of the garbage collector's whole-heap passes
        (`agile.utils.heap`: a pass over a simulator's process takes about a second)."""
        return super().learn(*args, **kwargs)

    def _configure_multi_gpu(self) -> None:
        """rsl-rl's multi-GPU set-up (NCCL, one CUDA device per rank), extended to CPU ranks with gloo."""
        from agile.rl_env.rsl_rl.distributed import init_cpu_process_group, rank_from_env

        rank = rank_from_env()
        if rank is None or not str(self.device).startswith("cpu"):
            super()._configure_multi_gpu()
            return
        self.gpu_world_size, self.is_distributed = rank.world_size, True
        self.gpu_local_rank, self.gpu_global_rank = rank.local_rank, rank.rank
        self.cfg["multi_gpu"] = {"global_rank": rank.rank, "local_rank": rank.local_rank,
                                 "world_size": rank.world_size}
        init_cpu_process_group(rank)


class CheckpointingDistillationRunner(CheckpointingRunner, DistillationRunner):
    """The same for distillation (rsl-rl's DistillationRunner refuses to learn before a teacher is loaded)."""


def training_runner(env, agent_cfg, log_dir: str | None, wrap=None, overrides=()) -> CheckpointingRunner:
    """The runner `agile train` trains with (and `agile benchmark` times): the checkpointing runner of the agent
    config over `wrap(env, nan_check_every_steps)` (default `RslRlVecEnvWrapper`), rsl-rl's per-step NaN check moved
    into the wrapper (`defer_nan_check`), the config's matmul precision set for the process; `overrides`, the
    configs' overrides the run was built with, go into every checkpoint."""
    from agile.rl_env.rsl_rl.runner_cfg import set_matmul_precision, to_rsl_rl_dict
    from agile.rl_env.rsl_rl.vecenv_wrapper import RslRlVecEnvWrapper, defer_nan_check

    train_cfg = to_rsl_rl_dict(agent_cfg)
    wrapped = (wrap or RslRlVecEnvWrapper)(env, defer_nan_check(train_cfg))
    set_matmul_precision(agent_cfg)
    return runner_class(agent_cfg)(wrapped, train_cfg, log_dir=log_dir, device=str(env.device), overrides=overrides)


def runner_class(agent_cfg) -> type[CheckpointingRunner]:
    """The checkpointing runner for a PPO or a distillation agent config."""
    from agile.rl_env.rsl_rl.runner_cfg import is_distillation

    return CheckpointingDistillationRunner if is_distillation(agent_cfg) else CheckpointingRunner
