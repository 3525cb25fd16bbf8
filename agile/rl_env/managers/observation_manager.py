"""Observation manager: groups of terms with noise, clip, scale and history, returned as a TensorDict."""

from __future__ import annotations

import dataclasses

import torch
from tensordict import TensorDict

from agile.rl_env.managers.manager_base import collect_terms, prepare_term, reset_term
from agile.rl_env.managers.term_cfg import ObsGroup, ObsTerm
from agile.utils.config import ConfigError


class TermHistory:
    """The last H values of one term, oldest first; a reset env's history is refilled with its next value. Also
    what the frozen-policy action keeps for a history policy (the same rule it was trained with)."""

    def __init__(self, length: int, num_envs: int, dim: int, device):
        self.buffer = torch.zeros(num_envs, length, dim, device=device)
        self.needs_fill = torch.ones(num_envs, dtype=torch.bool, device=device)

    def push(self, value: torch.Tensor) -> torch.Tensor:
        rolled = torch.cat((self.buffer[:, 1:], value.unsqueeze(1)), dim=1)
        filled = value.unsqueeze(1).expand_as(self.buffer)
        self.buffer.copy_(torch.where(self.needs_fill[:, None, None], filled, rolled))
        self.needs_fill.zero_()
        return self.buffer.flatten(1)

    def reset(self, env_mask: torch.Tensor) -> None:
        self.needs_fill |= env_mask


def check_noise_and_clip(term: ObsTerm, where: str) -> None:
    """Noise is drawn between n_min and n_max and the clip keeps values between its ends: either inverted
    would silently do something other than what it says."""
    if term.noise is not None and not term.noise.n_min <= term.noise.n_max:
        raise ConfigError(f"{where}.noise: n_min must be <= n_max, got n_min={term.noise.n_min}, "
                          f"n_max={term.noise.n_max}")
    if term.clip is not None and not term.clip[0] <= term.clip[1]:
        raise ConfigError(f"{where}.clip must be ordered (low <= high), got {tuple(term.clip)}")


def check_array_term(term: ObsTerm, group: ObsGroup, history_length: int, shape: tuple[int, ...], where: str) -> None:
    """A term with more than one value axis per env (an image) is passed on as it is: in a group of separate terms,
    without the arithmetic of vector terms."""
    if group.concatenate_terms:
        raise ConfigError(f"{where} has shape {shape} per env (an image): its group must keep terms apart "
                          "(concatenate_terms=False)")
    unsupported = [name for name, on in (("noise", term.noise is not None and group.enable_corruption),
                                         ("clip", term.clip is not None), ("scale", term.scale is not None),
                                         ("history_length", history_length > 0)) if on]
    if unsupported:
        raise ConfigError(f"{where} has shape {shape} per env (an image): {', '.join(unsupported)} cannot apply to "
                          "it; leave them unset")


class ObservationManager:
    def __init__(self, cfg, env):
        self.env = env
        self.group_cfgs: dict[str, ObsGroup] = {
            f.name: getattr(cfg, f.name) for f in dataclasses.fields(cfg) if isinstance(getattr(cfg, f.name), ObsGroup)}
        self.term_cfgs: dict[str, dict[str, ObsTerm]] = {}
        self.funcs: dict[str, dict] = {}
        self.histories: dict[str, dict[str, TermHistory]] = {}
        self.term_dims: dict[str, dict[str, int]] = {}
        """Values per env of each term (its history included); an image term counts its pixels x channels."""
        self.term_shapes: dict[str, dict[str, tuple[int, ...]]] = {}
        """Each term's shape per env: (dim,) for a vector term, e.g. (height, width, 3) for an image."""
        self.term_dtypes: dict[str, dict[str, torch.dtype]] = {}
        for group_name, group in self.group_cfgs.items():
            terms = collect_terms(group, ObsTerm)
            self.term_cfgs[group_name] = terms
            self.funcs[group_name] = {n: prepare_term(env, f"observation '{group_name}'", n, t) for n, t in terms.items()}
            self.histories[group_name] = {}
            self.term_dims[group_name] = {}
            self.term_shapes[group_name] = {}
            self.term_dtypes[group_name] = {}
            for name, term in terms.items():
                where = f"task '{env.task_name}': observations.{group_name}.{name}"
                check_noise_and_clip(term, where)
                value = self.funcs[group_name][name](env, **term.params)
                dim = value.shape[-1]
                length = group.history_length if group.history_length is not None else term.history_length
                self.term_dtypes[group_name][name] = value.dtype
                if value.dim() > 2:  # an image: passed on as it is
                    check_array_term(term, group, length, tuple(value.shape[1:]), where)
                    self.term_shapes[group_name][name] = tuple(value.shape[1:])
                    self.term_dims[group_name][name] = value[0].numel()
                    continue
                if length < 0:
                    where = f"observations.{group_name}" + ("" if group.history_length is not None else f".{name}")
                    raise ConfigError(f"task '{env.task_name}': {where}.history_length must be >= 0 (0: no history), "
                                      f"got {length}")
                if length > 0:
                    self.histories[group_name][name] = TermHistory(length, env.num_envs, dim, env.device)
                self.term_dims[group_name][name] = dim * max(length, 1)
                self.term_shapes[group_name][name] = (dim * max(length, 1),)

    @property
    def group_dims(self) -> dict[str, int]:
        return {g: sum(d.values()) for g, d in self.term_dims.items()}

    def space(self, batch: int | None = None):
        """The gymnasium space of what `compute()` returns: a Dict of groups, each a Box (concatenated group)
        or a Dict of its terms' Boxes; with `batch`, every Box has that leading dimension (the envs)."""
        import math

        import gymnasium as gym

        def box(shape: tuple[int, ...], dtype=torch.float32):
            shape = shape if batch is None else (batch, *shape)
            if dtype == torch.uint8:
                return gym.spaces.Box(0, 255, shape, dtype="uint8")
            return gym.spaces.Box(-math.inf, math.inf, shape)

        return gym.spaces.Dict({
            g: box((sum(dims.values()),)) if self.group_cfgs[g].concatenate_terms
            else gym.spaces.Dict({t: box(self.term_shapes[g][t], self.term_dtypes[g][t]) for t in dims})
            for g, dims in self.term_dims.items()})

    def compute_group(self, group_name: str) -> torch.Tensor | TensorDict:
        group = self.group_cfgs[group_name]
        values = {}
        for name, term in self.term_cfgs[group_name].items():
            obs = self.funcs[group_name][name](self.env, **term.params)
            if group.enable_corruption and term.noise is not None:
                obs = obs + torch.rand_like(obs) * (term.noise.n_max - term.noise.n_min) + term.noise.n_min
            if term.clip is not None:
                obs = obs.clamp(term.clip[0], term.clip[1])
            if term.scale is not None:
                obs = obs * term.scale
            history = self.histories[group_name].get(name)
            values[name] = history.push(obs) if history is not None else obs
        if group.concatenate_terms:
            return torch.cat(list(values.values()), dim=-1)
        return TensorDict(values, batch_size=[self.env.num_envs])

    def compute(self) -> TensorDict:
        return TensorDict({g: self.compute_group(g) for g in self.group_cfgs}, batch_size=[self.env.num_envs])

    def reset(self, env_mask: torch.Tensor) -> dict:
        for group_name in self.group_cfgs:
            for history in self.histories[group_name].values():
                history.reset(env_mask)
            for func in self.funcs[group_name].values():
                reset_term(func, env_mask)
        return {}
