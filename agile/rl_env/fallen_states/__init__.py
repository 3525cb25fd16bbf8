"""Fallen states for stand-up tasks: the dataset (collected before learning, cached on disk), the reset event that
starts episodes from it, and the pre-learn hook that connects the two."""

from __future__ import annotations

import copy

from agile.rl_env.fallen_states.dataset import (STATE_FIELDS, FallenStateDatasetCfg, FallenStates,
                                                collect_fallen_states, load_or_collect)
from agile.rl_env.fallen_states.reset import reset_from_fallen_dataset

__all__ = ["STATE_FIELDS", "FallenStateDatasetCfg", "FallenStates", "collect_fallen_states", "load_or_collect",
           "reset_from_fallen_dataset", "pre_learn"]


def pre_learn(env, task_name: str, use_cache: bool | None = None) -> None:
    """The pre-learn hook of a stand-up task (its registration's `pre_learn_entry_point`): for each reset event
    `reset_from_fallen_dataset`, load its dataset from the cache or collect it, and hand it over. `use_cache`
    overrides the dataset config's (train.py --no_cache). Called by train.py, play.py and eval.py after the env is
    built, before its first step."""
    names = [name for name in env.event_manager.terms("reset")
             if isinstance(env.event_manager.get_term(name), reset_from_fallen_dataset)]
    if not names:
        raise ValueError(f"task '{task_name}': pre_learn needs a reset event reset_from_fallen_dataset; its reset "
                         f"events: {env.event_manager.terms('reset')}")
    for name in names:
        params = env.event_manager.term_cfgs[name].params
        cfg = copy.deepcopy(params.get("dataset") or FallenStateDatasetCfg())
        if use_cache is not None:
            cfg.use_cache = use_cache
        robot_name = params["asset_cfg"].name if "asset_cfg" in params else "robot"
        env.event_manager.get_term(name).set_dataset(load_or_collect(env, cfg, task_name, robot_name))
