"""Blocks shared by the stand-up tasks (StandUp-T1, HeightTracking-G1)."""

from __future__ import annotations

from agile.tasks.stand_up.fallen_states import FallenStateDatasetCfg
from agile.rl_env.managers import EventTerm
from agile.tasks.stand_up import mdp

STAND_UP_PUSH_INTERVAL_S = (0.0, 10.0)
STAND_UP_PUSH_VELOCITY = (1.0, 0.5)
"""Pushes of the stand-up tasks: every 0-10 s, up to 1 m/s and 0.5 rad/s (harder than the velocity tasks')."""


def fallen_state_reset(standing_ratio: float) -> EventTerm:
    """Episodes start from the fallen-state dataset (collected or loaded when the env is built), a share
    `standing_ratio` standing; the states hold the joints too, so no joint reset follows."""
    return EventTerm(func=mdp.reset_from_fallen_dataset, mode="reset",
                     params={"standing_ratio": standing_ratio, "dataset": FallenStateDatasetCfg()})
