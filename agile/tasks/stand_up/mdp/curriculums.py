"""Curriculum terms of the stand-up task (AGILE T1 stand-up): the lift is weakened as more episodes reach
standing height, and envs move to rougher terrain rows as they end their episodes standing. Both are free of
host syncs, so they run inside a captured env step."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, ManagerTermBase, SceneEntityCfg
from agile.rl_env.mdp.curriculums import OUTCOME_STATE_ATTRS, EpisodeOutcomeCounter
from agile.rl_env.mdp.observations import base_height_above_ground

__all__ = ["adaptive_lift_curriculum", "terrain_levels_standing_at_timeout"]


class adaptive_lift_curriculum(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """AGILE `adaptive_lift_curriculum`: on every env step with resetting envs, the standing share is the fraction
    of them whose episode reached `standing_height_threshold_m` (the lift's `max_heights_m`: root height above
    the terrain, at any physics step); its exponential moving average (weight `ema_alpha` on the new share, 0 at
    the start) drives the lift's scale:
    - EMA > `ratio_to_decrease`: scale ×= (1 - `decay`);
    - otherwise, with `only_decrease` False: scale ×= (1 + `decay`), at most 1 (with True, AGILE's setting,
      it never rises);
    - a scale below `disable_below` becomes 0 (the lift is off for good: 0 never rises).
    A step without resetting envs changes nothing. The scale goes to the lift (`scale_forces`) on every call;
    returns it.

    The EMA and the scale are device tensors updated with masked math: no host sync.
    """

    training_state_attrs = ("standing_share_ema", "scale")  # restored on resume (ManagerTermBase)

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        params = cfg.params
        self.lift = env.action_manager.get_term(params.get("lift_action_name", "lift"))
        if not 0.0 < params.get("ema_alpha", 0.01) <= 1.0:
            raise ValueError(f"adaptive_lift_curriculum: ema_alpha must be in (0, 1], got {params['ema_alpha']}")
        if not 0.0 <= params.get("decay", 1.0e-4) < 1.0:
            raise ValueError(f"adaptive_lift_curriculum: decay must be in [0, 1), got {params['decay']}")
        self.standing_share_ema = torch.zeros((), device=env.device)
        """EMA of the share of resetting envs whose episode reached standing height."""
        self.scale = torch.ones((), device=env.device)
        """Lift strength in [0, 1]."""

    def __call__(self, env, env_mask, lift_action_name: str = "lift", standing_height_threshold_m: float = 0.55,
                 ratio_to_decrease: float = 0.7, ema_alpha: float = 0.01, decay: float = 1.0e-4,
                 disable_below: float = 0.01, only_decrease: bool = True) -> torch.Tensor:
        num_resets = env_mask.sum()
        num_standing = (env_mask & (self.lift.max_heights_m > standing_height_threshold_m)).sum()
        standing_share = num_standing / num_resets.clamp(min=1)
        any_reset = num_resets > 0
        ema = (1.0 - ema_alpha) * self.standing_share_ema + ema_alpha * standing_share
        self.standing_share_ema.copy_(torch.where(any_reset, ema, self.standing_share_ema))

        lowered = self.scale * (1.0 - decay)
        if only_decrease:  # a config flag (a Python bool), not a tensor value
            otherwise = self.scale
        else:
            otherwise = (self.scale * (1.0 + decay)).clamp(max=1.0)
        scale = torch.where(self.standing_share_ema > ratio_to_decrease, lowered, otherwise)
        scale = torch.where(scale < disable_below, 0.0, scale)
        self.scale.copy_(torch.where(any_reset, scale, self.scale))
        self.lift.scale_forces(self.scale)
        return self.scale.clone()


class terrain_levels_standing_at_timeout(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """AGILE `terrain_levels_standing_at_timeout`: an ending episode is a success when it ended by time-out (the
    termination manager's `time_outs`) with the robot standing: root height above the terrain under the height
    scanner `sensor_name` above `min_height_m` (AGILE T1: 0.8 × 0.65 m); any other ending is a failure. An env
    moves one terrain row up after `n_successes` successes and one row down after `n_failures` failures; each
    move clears both counts (as `terrain_levels_vel`). Returns the mean terrain level.
    """

    training_state_attrs = OUTCOME_STATE_ATTRS  # restored on resume (ManagerTermBase)

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        if env.sim.terrain is None:
            raise ValueError("terrain_levels_standing_at_timeout needs a terrain (SimCfg.terrain)")
        self.outcomes = EpisodeOutcomeCounter(env.num_envs, env.device)

    def __call__(self, env, env_mask, min_height_m: float = 0.52,
                 sensor_name: str | None = "height_measurement_sensor",
                 asset_cfg: SceneEntityCfg = ROBOT, n_successes: int = 5,
                 n_failures: int = 5) -> torch.Tensor:
        standing = base_height_above_ground(env, asset_cfg, sensor_name) > min_height_m
        succeeded = env.termination_manager.time_outs & standing
        move_up, move_down = self.outcomes.count(env_mask, succeeded, ~succeeded, n_successes, n_failures)
        env.sim.update_terrain_levels(move_up, move_down)
        return env.sim.terrain_levels.float().mean()
