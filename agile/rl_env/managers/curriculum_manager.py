"""Curriculum manager: terms called at every env step with the mask of envs being reset."""

from __future__ import annotations

import torch

from agile.rl_env.managers.manager_base import collect_terms, prepare_term
from agile.rl_env.managers.term_cfg import CurrTerm


class CurriculumManager:
    def __init__(self, cfg, env):
        self.env = env
        self.term_cfgs = collect_terms(cfg, CurrTerm)
        self.funcs = {n: prepare_term(env, "curriculum", n, t, skip_first=2) for n, t in self.term_cfgs.items()}
        self.state: dict[str, float | torch.Tensor] = {}

    @property
    def active_terms(self) -> list[str]:
        return list(self.term_cfgs)

    def compute(self, env_mask: torch.Tensor) -> dict:
        for name, cfg in self.term_cfgs.items():
            value = self.funcs[name](self.env, env_mask, **cfg.params)
            if value is not None:
                self.state[name] = value
        return {f"Curriculum/{name}": value for name, value in self.state.items()}

    def training_state(self) -> dict[str, torch.Tensor]:
        """{"<term>.<attr>": CPU copy} of every term's `training_state_attrs` (adaptive curricula; an attribute
        may be a dotted path, e.g. "outcomes.num_successes")."""
        return {f"{name}.{attr}": _attribute(func, attr).detach().cpu().clone()
                for name, func in self.funcs.items() for attr in getattr(func, "training_state_attrs", ())}

    def load_training_state(self, state: dict[str, torch.Tensor], resized=None) -> list[str]:
        """Copy `training_state()` entries back into the terms, in place (others hold references to them, e.g.
        the push event to pushing_curriculum's scale). `resized`: (the state's env count, (N,) the state's env each
        of this env's takes) where the state is of another env count, so that per-env entries are taken row by row.
        Returns the entries this env expected and the state lacked (a checkpoint from before a term existed: that
        term starts afresh); entries for terms this env does not have are an error."""
        expected = self.training_state()
        unknown = sorted(set(state) - set(expected))
        if unknown:
            raise ValueError(f"the checkpoint holds curriculum state {unknown} that this env's curriculum terms do "
                             f"not have; terms with state: {sorted(expected)}")
        for key, value in state.items():
            name, attr = key.split(".", 1)
            target = _attribute(self.funcs[name], attr)
            if resized is not None and value.dim() > 0 and value.shape[0] == resized[0] != target.shape[0]:
                value = value[resized[1]]  # a per-env entry
            if value.shape != target.shape:
                raise ValueError(f"curriculum state '{key}': checkpoint shape {tuple(value.shape)}, this env "
                                 f"{tuple(target.shape)} (a different num_envs?)")
            target.copy_(value.to(target.device))
        return sorted(set(expected) - set(state))


def _attribute(term, path: str) -> torch.Tensor:
    """The tensor at a dotted attribute path of a curriculum term ("scale", "outcomes.num_successes")."""
    value = term
    for part in path.split("."):
        value = getattr(value, part)
    return value
