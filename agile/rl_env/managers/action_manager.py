"""Action manager: splits the policy action among action terms, processes once per env step, applies."""

from __future__ import annotations

import torch

from agile.rl_env.managers.manager_base import build_class_terms
from agile.rl_env.managers.term_cfg import ActionTermCfg
from agile.utils.config import ConfigError


def is_training_only(term_cfg) -> bool:
    """Whether an action term's config marks it as a training aid (a lift, a harness): one rule for the built
    env (`ActionManager.training_only_terms`) and for configs made ready for inference before an env exists."""
    return isinstance(term_cfg, ActionTermCfg) and term_cfg.training_only


class ActionTerm:
    """Base of action terms. `cfg.class_type` names the term class."""

    def __init__(self, cfg, env):
        self.cfg = cfg
        self.env = env

    @property
    def action_dim(self) -> int:
        raise NotImplementedError

    def process_actions(self, actions: torch.Tensor) -> None:
        raise NotImplementedError

    def apply_actions(self) -> None:
        raise NotImplementedError

    def reset(self, env_mask: torch.Tensor) -> None:
        pass

    def io_description(self) -> dict:
        """This term in the exported IO descriptor: what a deployment needs to turn its slice of the policy output
        into robot commands. The base gives its type only; joint-target terms add joints, scale, offset, clip
        (the map sim2mujoco runs: target = action · scale + offset)."""
        return {"type": type(self).__name__}

    def demonstration_action(self) -> tuple[list[str], torch.Tensor]:
        """(names, (N, D) values): this term's part of a recorded demonstration's action, in the robot's own units
        (absolute joint targets, a command), so that a policy learned from the recording does not need this
        term's scaling. Valid after a step; a reset does not change it."""
        raise NotImplementedError(f"action term {type(self).__name__} has no demonstration action: it cannot be "
                                  "recorded")

    def link(self, terms: dict[str, ActionTerm]) -> None:
        """Called once all terms are built, with every term by name: a term that reads another term (a
        mirrored copy of its targets) looks it up here. Raise ValueError for a bad reference."""


class ActionManager:
    """Splits the policy's action among the terms. `action` (what the `last_action` observation and the action-rate
    rewards read) is the policy's raw output, as Isaac Lab's `ActionManager.action` and AGILE's `mdp.last_action`:
    the terms' clips bound the joint targets they make from it, not the action itself. Two rules keep it finite
    and bounded: a non-finite entry becomes 0 and ends the env's episode, and with `clip_actions` every entry is
    clamped to ±clip_actions first (Isaac Lab's agent setting, moved into the env so that training, evaluation,
    play and user code all step the same env)."""

    def __init__(self, cfg, env, clip_actions: float | None = None):
        if clip_actions is not None and not clip_actions > 0:
            raise ConfigError(f"task '{env.task_name}': clip_actions must be positive or None, got {clip_actions}")
        self.env = env
        self.clip_actions = clip_actions
        self.terms: dict[str, ActionTerm] = build_class_terms(cfg, env, "action")
        for name, term in self.terms.items():
            try:
                term.link(self.terms)
            except (ValueError, KeyError) as err:
                raise ConfigError(f"task '{env.task_name}', action term '{name}': {err}") from None
        self.total_action_dim = sum(t.action_dim for t in self.terms.values())
        n = env.num_envs
        self.action = torch.zeros(n, self.total_action_dim, device=env.device)
        self.prev_action = torch.zeros_like(self.action)
        self.prev_prev_action = torch.zeros_like(self.action)
        self.invalid_action = torch.zeros(n, dtype=torch.bool, device=env.device)
        """(N,) the last action had a non-finite entry: the env ends that step (terminated, counted as
        `Episode_Termination/invalid_action`)."""

    @property
    def active_terms(self) -> list[str]:
        return list(self.terms)

    @property
    def training_only_terms(self) -> list[str]:
        """The terms whose config says `training_only` (`is_training_only`): aids such as a lift or a harness,
        which inference, exports and students run without, and the fallen-state collection switches off."""
        return [name for name, term in self.terms.items() if is_training_only(term.cfg)]

    def get_term(self, name: str) -> ActionTerm:
        if name not in self.terms:
            raise KeyError(f"no action term '{name}'. Terms: {self.active_terms}")
        return self.terms[name]

    def policy_entity_name(self) -> str:
        """The one articulation the policy's action terms drive (`asset_name`): the robot whose joints an
        exported policy and the symmetry functions describe. Terms that pose a rigid object do not count."""
        from agile.sim.entities import Articulation

        names = sorted({term.cfg.asset_name for term in self.terms.values()
                        if term.action_dim > 0 and isinstance(self.env.scene[term.cfg.asset_name], Articulation)})
        if len(names) != 1:
            raise ValueError(f"the policy's action terms drive {len(names)} entities {names}; exports and symmetry "
                             f"need exactly one")
        return names[0]

    def process_action(self, action: torch.Tensor) -> None:
        if action.shape != self.action.shape:
            raise ValueError(f"action shape {tuple(action.shape)} != expected {tuple(self.action.shape)}")
        self.prev_prev_action.copy_(self.prev_action)
        self.prev_action.copy_(self.action)
        # the rule for a NaN or infinite entry: 0 (the term's offset, e.g. the default joint position), so that
        # observations and rewards stay finite; the env is ended and reset by the env step
        finite = torch.isfinite(action)
        torch.logical_not(finite.all(dim=-1), out=self.invalid_action)
        if self.clip_actions is not None:
            action = torch.clamp(action, -self.clip_actions, self.clip_actions)
        self.action.copy_(torch.where(finite, action, 0.0))
        start = 0
        for term in self.terms.values():
            term.process_actions(self.action[:, start:start + term.action_dim])
            start += term.action_dim

    def apply_action(self) -> None:
        for term in self.terms.values():
            term.apply_actions()

    def reset(self, env_mask: torch.Tensor) -> dict:
        m = env_mask.unsqueeze(-1)
        for buf in (self.action, self.prev_action, self.prev_prev_action):
            buf.masked_fill_(m, 0.0)
        for term in self.terms.values():
            term.reset(env_mask)
        return {}
