"""Term configurations: what a task file declares for each manager."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import field
from typing import Any

import torch

from agile.utils.config import configclass


@configclass
class SceneEntityCfg:
    """Joints or bodies of a scene entity (or bodies of a sensor), selected by name regexes; resolved to indices
    when the env is built. `name` is the entity's (or sensor's) name in the scene."""

    name: str = "robot"
    joint_names: str | list[str] | None = None
    body_names: str | list[str] | None = None
    preserve_order: bool = False
    # resolved by the manager (not to be set by hand)
    joint_ids: Any = None
    body_ids: Any = None

    def resolve(self, env) -> None:
        """Regexes -> index tensors on the env's device (or a full slice), so indexing costs no host copy."""
        robot = env.scene[self.name]
        self.joint_ids = slice(None)
        self.body_ids = slice(None)
        if self.joint_names is not None:
            ids, _ = robot.find_joints(self.joint_names, self.preserve_order)
            if ids != list(range(robot.num_joints)):
                self.joint_ids = torch.tensor(ids, dtype=torch.long, device=env.device)
        if self.body_names is not None:
            ids, _ = robot.find_bodies(self.body_names, self.preserve_order)
            if ids != list(range(robot.num_bodies)):
                self.body_ids = torch.tensor(ids, dtype=torch.long, device=env.device)


ROBOT = SceneEntityCfg("robot")
"""The default selector of most terms: the whole entity named "robot" (each term resolves its own copy)."""


def index_list(ids, count: int) -> list[int]:
    """Resolved `joint_ids`/`body_ids` (a full slice or an index tensor) as a host list; build time only."""
    return list(range(count)) if isinstance(ids, slice) else ids.tolist()


@configclass
class UniformNoiseCfg:
    """Additive noise drawn uniformly from [n_min, n_max]."""

    n_min: float = -1.0
    n_max: float = 1.0


def Unoise(n_min: float, n_max: float) -> UniformNoiseCfg:  # noqa: N802 (Isaac Lab's name)
    return UniformNoiseCfg(n_min=n_min, n_max=n_max)


@configclass
class ObsTerm:
    func: Callable | None = None
    params: dict[str, Any] = field(default_factory=dict)
    noise: UniformNoiseCfg | None = None
    clip: tuple[float, float] | None = None
    scale: float | None = None
    history_length: int = 0
    """0: no history. H > 0: the last H values, oldest first, flattened per term."""


@configclass
class ObsGroup:
    """Base class of an observation group; its ObsTerm fields are the terms, in order."""

    concatenate_terms: bool = True
    """True: the group is one (N, D) tensor. False: a TensorDict of per-term tensors."""
    enable_corruption: bool = False
    history_length: int | None = None
    """If set, overrides every term's history length."""


@configclass
class RewTerm:
    func: Callable | None = None
    weight: float = 0.0
    params: dict[str, Any] = field(default_factory=dict)


@configclass
class ActionTermCfg:
    """What every action term's config has (each term's config derives from it and sets `class_type`)."""

    class_type: type | None = None
    """The ActionTerm class built from this config."""
    asset_name: str = "robot"
    """The scene entity the term drives."""
    training_only: bool = False
    """A training aid (a lift, a harness): inference, exports, students and the fallen-state collection run without
    it (`is_training_only`)."""


@configclass
class DoneTerm:
    func: Callable | None = None
    params: dict[str, Any] = field(default_factory=dict)
    time_out: bool = False
    """Time-outs truncate the episode (the value bootstraps); all other terms are failures."""


METRIC_WHEN = ("step", "episode_end")
"""When a metric term is evaluated (`MetricTerm.when`)."""


@configclass
class MetricTerm:
    """An episode metric of the task (success, final height, ...) for training logs and evaluation, not tied to a
    command. `func(env, **params)` returns one value per env, (N,) float or bool; units in the term's name."""

    func: Callable | None = None
    params: dict[str, Any] = field(default_factory=dict)
    when: str = "step"
    """"step": evaluated after every env step (the state the rewards judge, an episode's last one included, its
    reset state not); the metric is the mean over the episode's steps, non-finite values not counted.
    "episode_end": evaluated once, when the episode ends, before the world is reset (the final state, and the
    termination manager's `time_outs`, `terminated` and `term_dones` of that step); a non-finite value (a world
    that blew up, counted by Episode_Termination/sim_unstable) counts 0."""


@configclass
class EventTerm:
    func: Callable | None = None
    mode: str = "reset"
    """'startup' (once, at build), 'reset' (every reset) or 'interval' (every interval_range_s per env)."""
    params: dict[str, Any] = field(default_factory=dict)
    interval_range_s: tuple[float, float] | None = None


@configclass
class CurrTerm:
    func: Callable | None = None
    params: dict[str, Any] = field(default_factory=dict)


class ManagerTermBase:
    """Base of stateful terms (a class in `func`): built once with (cfg, env), then called like a function.

    `training_state_attrs` names the tensor attributes that a resumed training must get back (an adaptive
    curriculum's running average and scale): they are saved with each checkpoint and restored in place."""

    training_state_attrs: tuple[str, ...] = ()

    def __init__(self, cfg, env):
        self.cfg = cfg
        self.env = env

    def prepare(self, env) -> None:
        """Called once when the env is built, after its startup events and first reset: a term that needs data
        made with the whole env (a reset event's fallen-state dataset) makes it here, so that `gym.make` builds
        exactly what training runs. Nothing by default."""

    def reset(self, env_mask) -> None:
        """Clear per-env state where env_mask (N,) is True."""
