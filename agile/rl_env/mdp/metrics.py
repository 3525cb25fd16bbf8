"""Metric terms (`MetricTerm`): what evaluation reports of an episode. Episode-end terms read the final state and
how the episode ended (the termination manager's buffers of the step that ends it); no host syncs."""

from __future__ import annotations

import torch

from agile.rl_env.managers import SceneEntityCfg
from agile.rl_env.managers import ROBOT
from agile.rl_env.mdp.observations import base_height_above_ground

__all__ = ["base_height_at_end", "ended_by_time_out", "not_standing_at_time_out", "standing_at_time_out"]


def ended_by_time_out(env) -> torch.Tensor:
    """(N,) bool: the episode ends now by a time-out and nothing else. A failure term firing in the same step, a
    world that blew up or a non-finite action make it a failure, as the env counts them (`terminated`)."""
    terms = env.termination_manager
    failed = terms.terminated | env.action_manager.invalid_action
    world = getattr(env, "world", None)
    if world is None:
        failed = failed | env.sim_unstable
    else:  # an agent of a multi-agent world: its world's blow-ups, and its death earlier (its robots frozen since)
        failed = failed | world.sim_unstable | env.died
    return terms.time_outs & ~failed


def base_height_at_end(env, asset_cfg: SceneEntityCfg = ROBOT, sensor_name: str | None = None) -> torch.Tensor:
    """(N,) root height [m] above the terrain under the height scanner `sensor_name` (above z=0 without one),
    as the height rewards measure it (`base_height_above_ground`); an episode-end term: the final height."""
    return base_height_above_ground(env, asset_cfg, sensor_name)


def standing_at_time_out(env, min_height_m: float, asset_cfg: SceneEntityCfg = ROBOT,
                         sensor_name: str | None = None) -> torch.Tensor:
    """(N,) 1.0 where the episode ends by a time-out (`ended_by_time_out`) with the root above `min_height_m`
    over the terrain (`base_height_above_ground`), else 0.0: the stand-up success. An episode-end term."""
    standing = base_height_above_ground(env, asset_cfg, sensor_name) > min_height_m  # NaN (blown up): False
    return (ended_by_time_out(env) & standing).float()


def not_standing_at_time_out(env, min_height_m: float, asset_cfg: SceneEntityCfg = ROBOT,
                             sensor_name: str | None = None) -> torch.Tensor:
    """(N,) 1 - `standing_at_time_out`: the share of failures, for criteria, which are maxima
    (`agile.tasks.catalogue`)."""
    return 1.0 - standing_at_time_out(env, min_height_m, asset_cfg, sensor_name)
