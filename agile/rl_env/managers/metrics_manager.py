"""Metrics manager: a task's episode metrics (`MetricTerm`: success, final height, ...) for training logs and
evaluation, whether or not the task has a command term (command terms keep their own, `CommandTerm.metrics`).

Every buffer is made at construction and written in place, with masked math only: the env step that updates the
metrics and ends episodes may be captured as one CUDA graph."""

from __future__ import annotations

import torch

from agile.rl_env.managers.command_manager import EpisodeMean, keep_episode_end
from agile.rl_env.managers.manager_base import collect_terms, prepare_term, reset_term
from agile.rl_env.managers.term_cfg import METRIC_WHEN, MetricTerm
from agile.utils.config import ConfigError, callable_name


class MetricsManager:
    """Per-step terms (`when="step"`) are averaged over each episode's steps by `update_metrics`; episode-end
    terms (`when="episode_end"`) are evaluated by `finish_episodes` for the envs whose episodes end. Both kinds
    of value then go to `last_episode_metrics["<name>"]` and to the log as `Metrics/<name>`."""

    def __init__(self, cfg, env):
        self.env = env
        self.term_cfgs: dict[str, MetricTerm] = collect_terms(cfg, MetricTerm)
        for name, term_cfg in self.term_cfgs.items():
            if term_cfg.when not in METRIC_WHEN:
                raise ConfigError(f"task '{env.task_name}', metric term '{name}': 'when' must be one of "
                                  f"{list(METRIC_WHEN)}, got {term_cfg.when!r}")
        self.funcs = {n: prepare_term(env, "metric", n, t) for n, t in self.term_cfgs.items()}
        n = env.num_envs
        self._step_means = {name: EpisodeMean(n, env.device) for name, c in self.term_cfgs.items()
                            if c.when == "step"}
        self._end_names = [name for name, c in self.term_cfgs.items() if c.when == "episode_end"]
        self.metrics: dict[str, torch.Tensor] = {
            name: self._step_means[name].value if name in self._step_means else torch.zeros(n, device=env.device)
            for name in self.term_cfgs}
        """(N,) each metric of each env's current episode: the mean so far of a per-step term; an episode-end
        term's value once its episode ends (0 before)."""
        self.last_episode_metrics: dict[str, torch.Tensor] = {name: torch.zeros(n, device=env.device)
                                                              for name in self.term_cfgs}
        """(N,) "<name>": each metric of each env's most recently ended episode (evaluation reads it where an
        episode ended); preallocated, written in place."""

    @property
    def active_terms(self) -> list[str]:
        return list(self.term_cfgs)

    def _evaluate(self, name: str) -> torch.Tensor:
        value = self.funcs[name](self.env, **self.term_cfgs[name].params)
        # a shape is known without a host sync: checking it is safe inside a captured step
        if not isinstance(value, torch.Tensor) or tuple(value.shape) != (self.env.num_envs,):
            got = f"shape {tuple(value.shape)}" if isinstance(value, torch.Tensor) else type(value).__name__
            raise ValueError(f"task '{self.env.task_name}', metric term '{name}': "
                             f"'{callable_name(self.term_cfgs[name].func)}' returned {got}; a metric needs one value "
                             f"per env, a tensor of shape ({self.env.num_envs},)")
        return value.float()

    def update_metrics(self) -> None:
        """The per-step terms; the env calls it once per step after the physics, before resetting ended envs."""
        for name, mean in self._step_means.items():
            mean.add(self._evaluate(name))

    def finish_episodes(self, env_mask: torch.Tensor) -> dict:
        """End the episodes of the masked envs; the env calls it before their worlds are reset. The episode-end
        terms are evaluated (for every env, kept for the masked ones), then every metric of the masked envs goes to
        `last_episode_metrics`. Returns the log entries "Metrics/<name>": means over the masked envs (0 where
        none ends)."""
        for name in self._end_names:
            value = self._evaluate(name)
            value = torch.where(torch.isfinite(value), value, 0.0)
            self.metrics[name].copy_(torch.where(env_mask, value, self.metrics[name]))
        count = env_mask.sum().clamp(min=1)
        log = {}
        for name, value in self.metrics.items():
            log[f"Metrics/{name}"] = keep_episode_end(value, self.last_episode_metrics[name], env_mask, count)
        return log

    def reset(self, env_mask: torch.Tensor) -> dict:
        """New episodes of the masked envs: nothing counted yet (every metric 0)."""
        for mean in self._step_means.values():
            mean.start(env_mask)
        for name in self._end_names:
            self.metrics[name].masked_fill_(env_mask, 0.0)
        for func in self.funcs.values():
            reset_term(func, env_mask)
        return {}


def merge_episode_metrics(env) -> dict[str, torch.Tensor]:
    """One view of the env's last-episode metrics: its command terms' ("<term>/<name>") and its metric terms'
    ("<name>"), the same tensors (written in place by each step). A key both give is an error naming both."""
    from_commands = env.command_manager.last_episode_metrics
    from_terms = env.metrics_manager.last_episode_metrics
    clash = sorted(set(from_commands) & set(from_terms))
    if clash:
        raise ConfigError(f"task '{env.task_name}': episode metric {clash} is named both by a command term's metrics "
                          f"(commands: {env.command_manager.active_terms}) and by a metric term (metrics: "
                          f"{env.metrics_manager.active_terms}); rename one")
    return {**from_commands, **from_terms}
