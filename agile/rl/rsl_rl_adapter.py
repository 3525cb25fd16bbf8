"""Every reach into rsl-rl's internals, in one place, for the rsl-rl version it was written for.

rsl-rl-lib 5.5.1 offers no public hook for what these do; each function names the members it reads or replaces, so
that an rsl-rl upgrade is checked here, and nowhere else. Importing this module with another rsl-rl version raises
`RslRlVersionError` naming both versions (`check_rsl_rl_version`): a private member that moved would otherwise fail
late, or silently.
"""

from __future__ import annotations

import contextlib
import importlib.metadata

import torch

RSL_RL_VERSION = "5.5.1"
"""The rsl-rl-lib version these reaches were written for (pyproject.toml pins it)."""


class RslRlVersionError(RuntimeError):
    """The installed rsl-rl-lib is not the version the adapter was written for."""


def check_rsl_rl_version(installed: str | None = None) -> None:
    """Raise RslRlVersionError unless `installed` (default: the installed rsl-rl-lib's version) is RSL_RL_VERSION."""
    installed = importlib.metadata.version("rsl-rl-lib") if installed is None else installed
    if installed != RSL_RL_VERSION:
        raise RslRlVersionError(
            f"agile.rl.rsl_rl_adapter reaches into rsl-rl-lib {RSL_RL_VERSION}'s internals (Logger's buffers and "
            f"device, OnPolicyRunner._configure_multi_gpu, Distillation._raw_teacher, GaussianDistribution."
            f"_distribution); rsl-rl-lib {installed} is installed: install rsl-rl-lib=={RSL_RL_VERSION}")


check_rsl_rl_version()


def gaussian_mean_std(distribution) -> tuple[torch.Tensor, torch.Tensor]:
    """The mean and std of an rsl-rl `GaussianDistribution`'s current torch distribution (`_distribution`)."""
    return distribution._distribution.loc, distribution._distribution.scale


def distillation_teacher(algorithm) -> torch.nn.Module:
    """rsl-rl's `Distillation` teacher model itself, not its compiled wrapper (`_raw_teacher`): the module whose state
    dict a checkpoint or an export holds."""
    return algorithm._raw_teacher


def rebuilt_logger(cls, runner):
    """The runner's logger as a `cls` (a subclass of rsl-rl's `Logger`), built with the arguments the runner gave its
    own (read back from the logger's attributes: rsl-rl passes them nowhere else) and the repositories whose state it
    logs; before training starts (rsl-rl creates the tensorboard writer in `learn`)."""
    logger = runner.logger
    new = cls(log_dir=logger.log_dir, cfg=logger.cfg, env_cfg=logger.env_cfg, num_envs=logger.num_envs,
              is_distributed=runner.is_distributed, gpu_world_size=runner.gpu_world_size,
              gpu_global_rank=runner.gpu_global_rank, device=logger.device)
    new.git_status_repos = logger.git_status_repos
    return new


@contextlib.contextmanager
def logger_gathering_on_host(logger):
    """Inside: rsl-rl's `Logger.log` gathers each episode extra on the host, not on `logger.device` (the device is read
    nowhere else in `log`): for extras already moved to the host in one copy."""
    device, logger.device = logger.device, torch.device("cpu")
    try:
        yield
    finally:
        logger.device = device


def set_git_status_repos(runner, paths: list[str]) -> None:
    """The repositories whose git status rsl-rl stores with a run, replacing its default (its own installed package,
    not a repository); rsl-rl's `add_git_repo_to_log` only adds to that default."""
    runner.logger.git_status_repos = list(paths)


class CpuRanksRunnerMixin:
    """An rsl-rl runner whose multi-process set-up (`_configure_multi_gpu`, NCCL with one CUDA device per rank) also
    takes CPU ranks, with gloo. In front of `OnPolicyRunner` in the bases."""

    def _configure_multi_gpu(self) -> None:
        from agile.rl.distributed import init_cpu_process_group, rank_from_env

        rank = rank_from_env()
        if rank is None or not str(self.device).startswith("cpu"):
            super()._configure_multi_gpu()
            return
        self.gpu_world_size, self.is_distributed = rank.world_size, True
        self.gpu_local_rank, self.gpu_global_rank = rank.local_rank, rank.rank
        self.cfg["multi_gpu"] = {"global_rank": rank.rank, "local_rank": rank.local_rank,
                                 "world_size": rank.world_size}
        init_cpu_process_group(rank)
