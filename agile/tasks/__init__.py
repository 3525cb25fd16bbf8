"""Task registry: importing this package registers every agile task with gymnasium."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import yaml

from agile.tasks import debug  # noqa: F401  (registration side effect)
from agile.tasks.velocity import g1, go1, t1  # noqa: F401  (registration side effect)
from agile.tasks.velocity_height import g1 as height_g1  # noqa: F401  (registration side effect)
from agile.tasks.stand_up import t1 as stand_up_t1  # noqa: F401  (registration side effect)
from agile.tasks.height_tracking import g1 as height_tracking_g1  # noqa: F401  (registration side effect)
from agile.tasks.motion_tracking import g1 as tracking_g1  # noqa: F401  (registration side effect)
from agile.tasks import multi_agent  # noqa: F401  (registration side effect)
from agile.tasks.pick_place import g1 as pick_place_g1  # noqa: F401  (registration side effect)
from agile.tasks.registration import SPEC_KWARG, TASK_KINDS, TaskSpec  # noqa: F401  (TASK_KINDS: named here too)
from agile.errors import AgileError
from agile.utils.config import load_entry_point


class UnknownTaskError(AgileError, KeyError):
    """A task ID that is not registered (a KeyError too, as a registry lookup's)."""

    def __str__(self) -> str:  # the message, not KeyError's quoted repr of it
        return self.args[0]


def registered_tasks() -> list[str]:
    """IDs of the agile tasks registered with gymnasium."""
    return sorted(spec_id for spec_id, spec in gym.registry.items() if SPEC_KWARG in spec.kwargs)


def task_spec(task: str) -> TaskSpec:
    """The task's `TaskSpec` (UnknownTaskError naming the registered tasks for an ID that is none)."""
    spec = gym.registry.get(task)
    if spec is None or SPEC_KWARG not in spec.kwargs:
        raise UnknownTaskError(f"unknown task '{task}'. Registered tasks: {', '.join(registered_tasks())}")
    return spec.kwargs[SPEC_KWARG]


def task_kind(task: str) -> str:
    """The task's kind, one of TASK_KINDS (see `agile.tasks.registration.TASK_KINDS`)."""
    return task_spec(task).kind


def load_cfgs(task: str, trainer: str = "rsl_rl"):
    """(env cfg, agent cfg) instances of a registered task; the agent cfg of `trainer` (one of the task spec's
    `trainer_cfgs`, or "rsl_rl": its runner config)."""
    spec = task_spec(task)
    runner_cfg = spec.runner_cfg_entry_point if trainer == "rsl_rl" else spec.trainer_cfgs[trainer]
    return load_entry_point(spec.env_cfg_entry_point)(), load_entry_point(runner_cfg)()


PRETRAINED_DIR = Path(__file__).resolve().parents[1] / "data" / "policy"
PRETRAINED_CONDITIONS = PRETRAINED_DIR / "conditions.yaml"
MULTI_AGENT_CHECKPOINTS = "*/model_*.pt"
"""A multi-agent task's shipped checkpoints inside its folder: one per agent group, as a training run folder holds them."""


def shipped_policy_variant(task: str, env_cfg=None) -> str | None:
    """For a task whose shipped policies differ by one config field (its registration's `shipped_policy_per`,
    e.g. "commands.motion.motion_file": one policy per shipped motion), that field's value in `env_cfg` (the
    task's default config when None); None for other tasks and for a value that is not a shipped name (a
    user's own file path: agile ships no policy trained on it)."""
    field = task_spec(task).shipped_policy_per
    if field is None:
        return None
    value = env_cfg if env_cfg is not None else load_cfgs(task)[0]
    for part in field.split("."):
        value = getattr(value, part)
    value = str(value)
    return value if value and Path(value).name == value and not Path(value).suffix else None


def pretrained_policy(task: str, env_cfg=None) -> Path | None:
    """The policy shipped with agile for a task (agile/data/policy/<task>.pt, or the file of the task its
    registration names as `shipped_policy`: two IDs of one task share one policy), if there is one. A task
    with `shipped_policy_per` ships one per value of that field: <task>.<value>.pt (see
    `shipped_policy_variant`; `env_cfg` is the config after the user's overrides). A multi-agent task ships a
    folder shaped as its training run folder, agile/data/policy/<task>/<group>/model_<iteration>.pt."""
    spec = task_spec(task)
    name = spec.policy_name
    if spec.kind == "multi_agent":
        folder = PRETRAINED_DIR / name
        return folder if any(folder.glob(MULTI_AGENT_CHECKPOINTS)) else None
    if spec.shipped_policy_per is not None:
        variant = shipped_policy_variant(task, env_cfg)
        if variant is None:
            return None
        name = f"{name}.{variant}"
    path = PRETRAINED_DIR / f"{name}.pt"
    return path if path.is_file() else None


def shipped_policy_files(task: str) -> list[Path]:
    """Every policy file agile ships for the task (several for a task with one per value of a config field, one per
    agent group for a multi-agent task), found without building or loading its configs."""
    spec = task_spec(task)
    if spec.kind == "multi_agent":
        return sorted((PRETRAINED_DIR / spec.policy_name).glob(MULTI_AGENT_CHECKPOINTS))
    if spec.shipped_policy_per is not None:
        return sorted(PRETRAINED_DIR.glob(f"{spec.policy_name}.*.pt"))
    path = PRETRAINED_DIR / f"{spec.policy_name}.pt"
    return [path] if path.is_file() else []


def pretrained_policy_conditions(task: str) -> tuple[str, list[str]]:
    """(what the shipped policy was trained on, the config overrides `env.<field>=<value>` that give that
    env) from agile/data/policy/conditions.yaml, keyed by the policy file's name (two IDs of one task share
    its entry); ("", []) when it was trained on the task as registered."""
    with open(PRETRAINED_CONDITIONS) as f:
        spec = (yaml.safe_load(f) or {}).get(  # a file of comments only: no policy has conditions
            task_spec(task).policy_name)
    if spec is None:
        return "", []
    return spec["trained_on"], list(spec["env_overrides"])
