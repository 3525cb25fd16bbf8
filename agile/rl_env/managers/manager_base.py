"""What every manager shares: collecting terms from a config and preparing their functions."""

from __future__ import annotations

import copy
import dataclasses
import inspect
import re

from agile.rl_env.managers.term_cfg import ManagerTermBase, SceneEntityCfg
from agile.utils.config import ConfigError, callable_name


def collect_terms(cfg, term_type) -> dict:
    """{field name: term cfg} for the fields of `cfg` that hold a `term_type` (None disables a term)."""
    if cfg is None:
        return {}
    terms = {}
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        if isinstance(value, term_type):
            terms[f.name] = value
    return terms


RANGE_PARAM = re.compile(r"_range(_[a-z0-9]+)?$|_distribution_params$")
"""Param names of ranges: `*_range`, `*_range_<unit>`, `*_distribution_params`."""


def range_params(key: str, value) -> list[tuple[str, tuple]]:
    """(label, (low, high)) of a param that is a range by its name: a pair, or pairs per axis
    ({"x": (low, high), ...}). Terms draw uniformly between the ends, so an inverted range would silently
    draw outside what it says."""
    if not RANGE_PARAM.search(key):
        return []
    pairs = value.items() if isinstance(value, dict) else [(None, value)]
    return [(key if axis is None else f"{key}['{axis}']", pair) for axis, pair in pairs
            if isinstance(pair, (tuple, list)) and len(pair) == 2
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in pair)]


def prepare_term(env, manager: str, name: str, term_cfg, skip_first: int = 1):
    """Resolve entity selectors in params, instantiate class terms and check the params fit the function.

    Errors name the task, manager, term and field.
    """
    where = f"task '{env.task_name}', {manager} term '{name}'"
    func = term_cfg.func
    if func is None:
        raise ConfigError(f"{where}: 'func' is not set")
    if not inspect.isclass(func):
        # entity selectors left at their defaults are resolved too (a copy per term)
        for p in list(inspect.signature(func).parameters.values())[skip_first:]:
            if isinstance(p.default, SceneEntityCfg) and p.name not in term_cfg.params:
                term_cfg.params[p.name] = copy.deepcopy(p.default)
    for key, value in term_cfg.params.items():
        # a standard deviation divides: by the naming rule (`std`, `std_rad`, ...) it must be positive
        if (key == "std" or key.startswith("std_")) and isinstance(value, (int, float)) and not value > 0:
            raise ConfigError(f"{where}, param '{key}': a standard deviation must be positive, got {value}")
        for label, pair in range_params(key, value):
            if not pair[0] <= pair[1]:
                raise ConfigError(f"{where}, param '{label}': a range must be ordered (low <= high), got {tuple(pair)}")
        if isinstance(value, SceneEntityCfg):
            try:
                value.resolve(env)
            except (ValueError, KeyError) as err:
                raise ConfigError(f"{where}, param '{key}': {err}") from None
    if inspect.isclass(func):
        if not issubclass(func, ManagerTermBase):
            raise ConfigError(f"{where}: class {callable_name(func)} must derive from ManagerTermBase")
        try:
            func = func(term_cfg, env)
        except (ValueError, KeyError) as err:
            raise ConfigError(f"{where}: {err}") from None
        signature = inspect.signature(func.__call__)
    else:
        signature = inspect.signature(func)
    params = list(signature.parameters.values())[skip_first:]
    accepts_kwargs = any(p.kind is p.VAR_KEYWORD for p in params)
    names = {p.name for p in params}
    for key in term_cfg.params:
        if key not in names and not accepts_kwargs:
            raise ConfigError(f"{where}: '{callable_name(term_cfg.func)}' has no parameter '{key}' "
                              f"(parameters: {sorted(names)})")
    missing = [p.name for p in params if p.default is p.empty and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
               and p.name not in term_cfg.params]
    if missing:
        raise ConfigError(f"{where}: missing params {missing} for '{callable_name(term_cfg.func)}'")
    return func


def reset_term(func, env_mask) -> None:
    if isinstance(func, ManagerTermBase):
        func.reset(env_mask)


def build_class_terms(cfg, env, manager: str) -> dict:
    """{field name: cfg.class_type(cfg, env)} for the term configs of `cfg` (None disables a term)."""
    terms = {}
    if cfg is None:
        return terms
    for f in dataclasses.fields(cfg):
        term_cfg = getattr(cfg, f.name)
        if term_cfg is None:
            continue
        class_type = getattr(term_cfg, "class_type", None)
        if class_type is None:
            raise ConfigError(f"task '{env.task_name}', {manager} term '{f.name}': cfg has no class_type")
        try:
            terms[f.name] = class_type(term_cfg, env)
        except (ValueError, KeyError) as err:
            raise ConfigError(f"task '{env.task_name}', {manager} term '{f.name}': {err}") from None
    return terms
