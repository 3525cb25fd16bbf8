"""The stand-up family's startup dataset, as the task spec's `startup_dataset` names it: what the env build calls for
a task that is to collect its fallen states anew (the commands' --no_cache) instead of loading the disk cache."""

from __future__ import annotations

import dataclasses

from agile.rl_env.managers import EventTerm
from agile.tasks.stand_up.fallen_states.dataset import FallenStateDatasetCfg
from agile.tasks.stand_up.fallen_states.reset import reset_from_fallen_dataset

__all__ = ["collect_fallen_states_anew"]


def collect_fallen_states_anew(env_cfg) -> None:
    """Every `reset_from_fallen_dataset` event of `env_cfg` collects its dataset instead of loading the cache (its
    `dataset` config, the default one where it names none, with `use_cache` off)."""
    for term in vars(env_cfg.events or object()).values():
        if isinstance(term, EventTerm) and term.func is reset_from_fallen_dataset:
            dataset = term.params.get("dataset") or FallenStateDatasetCfg()
            term.params["dataset"] = dataclasses.replace(dataset, use_cache=False)
