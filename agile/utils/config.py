"""Config helpers: a dataclass decorator for term-style configs, overrides by dotted path, dumping.

Configs are stdlib dataclasses. `configclass` only adds two conveniences so that a task file can read
like Isaac Lab's (`track_lin_vel_xy_exp = RewTerm(...)`):
- class attributes without an annotation become fields (annotated with the type of their value);
- mutable defaults (other configs, lists, dicts) are deep-copied per instance, so that changing one
  env config never changes another.
"""

from __future__ import annotations

import ast
import copy
import dataclasses
import importlib
import inspect
import math
import typing
from collections.abc import Callable
from typing import Any

from agile.errors import AgileError


def configclass(cls=None, **dataclass_kwargs):
    """Turn a class into a dataclass whose defaults are copied per instance."""

    def wrap(cls):
        annotations = dict(cls.__dict__.get("__annotations__", {}))
        _check_field_order(cls, annotations)
        for name, value in list(cls.__dict__.items()):
            if name.startswith("__") or name in annotations:
                continue
            if inspect.isfunction(value) or isinstance(value, (classmethod, staticmethod, property)):
                continue
            annotations[name] = type(value)
        cls.__annotations__ = annotations
        for name in annotations:
            if name not in cls.__dict__:
                continue
            value = cls.__dict__[name]
            if isinstance(value, dataclasses.Field):
                continue
            if _is_mutable(value):
                setattr(cls, name, dataclasses.field(default_factory=_copier(value)))
        return dataclasses.dataclass(cls, **dataclass_kwargs)

    return wrap if cls is None else wrap(cls)


def _check_field_order(cls, annotations: dict) -> None:
    """Refuse a class whose new fields mix styles so that the dataclass would reorder them: annotated fields
    become the first fields and unannotated ones follow, so `a = ...` then `b: T = ...` would put b before a
    (the order of terms is an observation's layout and the order events draw their random numbers in)."""
    inherited = {f.name for base in cls.__mro__[1:] if dataclasses.is_dataclass(base) for f in dataclasses.fields(base)}
    unannotated = None
    for name, value in cls.__dict__.items():
        if name.startswith("__") or name in inherited:
            continue
        if name not in annotations:
            if inspect.isfunction(value) or isinstance(value, (classmethod, staticmethod, property)):
                continue
            unannotated = unannotated or name
        elif unannotated is not None:
            raise TypeError(f"configclass {cls.__name__}: field '{name}' has a type annotation but comes after "
                            f"'{unannotated}', which has none; the fields would be reordered (annotated first). "
                            "Annotate every field of the class or none.")


def _is_mutable(value) -> bool:
    return dataclasses.is_dataclass(value) or isinstance(value, (list, dict, set))


def _copier(value):
    return lambda: copy.deepcopy(value)


# ---------------------------------------------------------------------------------------------
# Overrides: "env.rewards.track_lin_vel_xy_exp.weight=2.0"


class ConfigError(AgileError, ValueError):
    """A config field is missing, misspelt or of the wrong type."""


def checked_cfg(cls, values: dict, name: str):
    """A settings dataclass `cls` (with `check()`) from the dict a config carries under `name` (an algorithm
    extension's settings): an unknown field is named with the valid ones, a bad value by `check()`."""
    fields = list(cls.__dataclass_fields__)
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise ConfigError(f"{name}: unknown {unknown}; its fields: {fields}")
    cfg = cls(**values)
    cfg.check()
    return cfg


def parse_value(text: str):
    """Python literal if it parses as one (numbers, bools, None, tuples, lists, dicts), else the string."""
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        lowered = text.lower()
        if lowered in ("true", "false"):
            return lowered == "true"
        if lowered in ("none", "null"):
            return None
        return text


def _child(obj, part: str, walked: str):
    """`obj`'s field or key `part`; ConfigError naming `walked` (the path so far) and what is there instead."""
    if isinstance(obj, dict):
        if part not in obj:
            raise ConfigError(f"'{walked}' has no key '{part}'. Keys: {sorted(obj)}")
        return obj[part]
    if dataclasses.is_dataclass(obj):
        names = [f.name for f in dataclasses.fields(obj)]
        if part not in names:
            raise ConfigError(f"'{walked}' has no field '{part}'. Fields: {names}")
        return getattr(obj, part)
    raise ConfigError(f"'{walked}' is a {type(obj).__name__}, it has no field '{part}'")


def get_by_path(cfg, path: str, root_name: str = "cfg"):
    """`cfg.<path>` (dots; dict keys allowed); ConfigError naming the first part that is not there."""
    obj, walked = cfg, root_name
    for part in path.split("."):
        obj, walked = _child(obj, part, walked), f"{walked}.{part}"
    return obj


def set_by_path(cfg, path: str, value, root_name: str = "cfg") -> None:
    """Set `cfg.<path>` (dots; dict keys allowed) to `value`, checking that the field exists and the type fits."""
    parent_path, _, name = path.rpartition(".")
    parent = get_by_path(cfg, parent_path, root_name) if parent_path else cfg
    walked = f"{root_name}.{parent_path}" if parent_path else root_name
    current = _child(parent, name, walked)
    if current is None and isinstance(value, dict) and dataclasses.is_dataclass(parent):
        new = _config_group_from_dict(parent, name, value, f"{walked}.{name}")
    else:
        new = _coerce(current, value, f"{walked}.{name}")
    if isinstance(parent, dict):
        parent[name] = new
    else:
        setattr(parent, name, new)


def _config_group_from_dict(parent, name: str, values: dict, path: str):
    """An unset optional config group (`field: SomeCfg | None = None`) switched on by an override such as
    `agent.algorithm.l2c2={}` or `agent.algorithm.l2c2={'lambda_actor': 0.5}`: the group built from its defaults and those values.
    A field that is not a config group keeps the dict as it is."""
    hint = typing.get_type_hints(type(parent)).get(name)
    groups = [t for t in typing.get_args(hint) or (hint,) if isinstance(t, type) and dataclasses.is_dataclass(t)]
    if not groups:
        return values
    group = groups[0]
    names = [f.name for f in dataclasses.fields(group)]
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise ConfigError(f"'{path}' ({group.__name__}) has no field {unknown[0]!r}. Fields: {names}")
    return group(**values)


def same_setting(current, text: str) -> bool:
    """Whether the override value `text` would leave a field holding `current` as it is (after the coercion an
    override gets: 1 for 1.0, a list for a tuple)."""
    try:
        return _coerce(current, parse_value(text), "field") == current
    except ConfigError:  # a value of another type: not the same
        return False


def _coerce(current, value, name: str):
    if current is None or value is None:
        return value
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"'{name}' expects a bool, got {value!r}")
        return value
    if isinstance(current, float) and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(current, int) and isinstance(value, float) and value.is_integer():
        return int(value)
    if isinstance(current, tuple) and isinstance(value, list):
        return tuple(value)
    if isinstance(current, (int, float, str, tuple, list, dict)) and not isinstance(value, type(current)):
        raise ConfigError(f"'{name}' expects {type(current).__name__}, got {type(value).__name__} {value!r}")
    if dataclasses.is_dataclass(current) and not dataclasses.is_dataclass(value):
        raise ConfigError(f"'{name}' is a config group ({type(current).__name__}); set one of its fields instead")
    return value


def split_override(item: str) -> tuple[str, str]:
    """(path, value text) of a "root.path=value" override (leading dashes dropped from the path)."""
    if "=" not in item:
        raise ConfigError(f"override '{item}' is not of the form path=value")
    path, text = item.split("=", 1)
    return path.lstrip("-"), text


def apply_overrides(roots: dict[str, Any], overrides: list[str]) -> None:
    """Apply "root.path=value" strings, e.g. roots={"env": env_cfg, "agent": agent_cfg}."""
    for item in overrides:
        path, text = split_override(item)
        root, _, rest = path.partition(".")
        if root not in roots or not rest:
            raise ConfigError(f"override '{item}' must start with one of {sorted(roots)} followed by a field path")
        set_by_path(roots[root], rest, parse_value(text), root_name=root)


# ---------------------------------------------------------------------------------------------
# Dumping and entry points


def to_dict(cfg) -> Any:
    """Plain dict/list/scalar form of a config, with callables written as 'module:qualname'."""
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        return {f.name: to_dict(getattr(cfg, f.name)) for f in dataclasses.fields(cfg)}
    if isinstance(cfg, dict):
        return {str(k): to_dict(v) for k, v in cfg.items()}
    if isinstance(cfg, (list, tuple)):
        return [to_dict(v) for v in cfg]
    if isinstance(cfg, float) and not math.isfinite(cfg):
        return str(cfg)
    if isinstance(cfg, (int, float, str, bool)) or cfg is None:
        return cfg
    if callable(cfg):
        return callable_name(cfg)
    return repr(cfg)


def callable_name(obj: Callable) -> str:
    return f"{getattr(obj, '__module__', '?')}:{getattr(obj, '__qualname__', repr(obj))}"


def load_entry_point(spec: str | Callable):
    """Resolve 'package.module:Attr' to the attribute (callables pass through)."""
    if callable(spec):
        return spec
    module_name, _, attr = spec.partition(":")
    obj = importlib.import_module(module_name)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def check_range(name: str, value, minimum: float | None = None, maximum: float | None = None) -> None:
    """Raise ValueError naming `name` unless `value` is an ordered (low, high) pair within [minimum, maximum]."""
    low, high = value
    if not low <= high:
        raise ValueError(f"{name} must be ordered (low <= high), got {tuple(value)}")
    if (minimum is not None and low < minimum) or (maximum is not None and high > maximum):
        raise ValueError(f"{name} must lie within [{minimum}, {maximum}], got {tuple(value)}")


def domain_problems(cfg, positive: tuple[str, ...] = (), non_negative: tuple[str, ...] = (),
                    ordered: tuple[str, ...] = ()) -> list[str]:
    """'<field> must be ..., got <value>' for each named field of `cfg` outside its domain: positive, >= 0, or an
    ordered (low, high) pair. A field set to None (unset, or "every sample") is skipped."""
    problems = []
    for name in positive:
        value = getattr(cfg, name)
        if value is not None and not value > 0:
            problems.append(f"{name} must be positive, got {value}")
    for name in non_negative:
        value = getattr(cfg, name)
        if value is not None and not value >= 0:
            problems.append(f"{name} must be >= 0, got {value}")
    for name in ordered:
        value = getattr(cfg, name)
        if value is not None and not value[0] <= value[1]:
            problems.append(f"{name} must be ordered (low <= high), got {tuple(value)}")
    return problems
