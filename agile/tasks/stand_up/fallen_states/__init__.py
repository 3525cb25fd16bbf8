"""Fallen states for stand-up tasks: the dataset (collected when the env is built, cached on disk) and the reset
event that makes it (`reset_from_fallen_dataset.prepare`) and starts episodes from it."""

from __future__ import annotations

from agile.tasks.stand_up.fallen_states.dataset import (STATE_FIELDS, FallenStateDatasetCfg, FallenStates,
                                                        collect_fallen_states, load_or_collect)
from agile.tasks.stand_up.fallen_states.reset import reset_from_fallen_dataset

__all__ = ["STATE_FIELDS", "FallenStateDatasetCfg", "FallenStates", "collect_fallen_states", "load_or_collect",
           "reset_from_fallen_dataset"]
