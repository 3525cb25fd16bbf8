"""The task catalogue: what each registered task is, what policy agile ships for it, and how that policy is
evaluated. Derived from the gymnasium registry (no hand-kept list of IDs): a new registration appears here.

A task's registration may set `eval_criteria` ({metric: maximum}), `eval_minima` ({metric: minimum}, for shares of
success such as a cube lifted) or `eval_settings` in its kwargs; otherwise the defaults below apply (the velocity-height
defaults add the base-height error)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from agile.tasks import TASK_KINDS, load_cfgs, pretrained_policy, registered_tasks, task_kind, task_spec

CATALOGUE_KINDS = TASK_KINDS
"""trainable: PPO on its own reward; distilled: a student whose agent cfg is a DistillationRunnerCfg;
debug: watched and driven by hand in the GUI (one may play the policy of the task it debugs); multi_agent: a
MultiAgentEnv (several robots, own rates)."""
EVALUATED_KINDS = ("trainable", "distilled", "multi_agent")
"""The kinds whose shipped policy eval_all.py evaluates (a debug task's policy, if any, is another task's, evaluated
there); a multi-agent task's criteria bound each of its agents."""

DEFAULT_EVAL_SETTINGS = {"num_envs": 512, "num_episodes": 1, "episode_length_s": 20.0}
"""GPU evaluation: 512 envs for one 20 s episode each, pushes off (what docs/results/velocity/eval_*_h100.json used)."""
TINY_CPU_SETTINGS = {"num_envs": 2, "num_episodes": 1, "episode_length_s": 1.0}
"""A setting that only proves the pipeline runs (CI): too short to judge a policy, so criteria are not checked."""

DEFAULT_CRITERIA = {"fall_rate": 0.05, "lin_vel_error_mps": 0.25, "ang_vel_error_radps": 0.3}
"""Maxima a shipped velocity policy must meet; the shipped T1 and G1 policies measured 0.002 falls per episode,
0.06-0.14 m/s and 0.15 rad/s on an H100 (docs/results/velocity/eval_*_h100.json): about twice that is a regression."""
HEIGHT_CRITERIA = {**DEFAULT_CRITERIA, "base_height_error_m": 0.05}
"""Tasks with a base-height command also bound the height error (commanded minus measured above the terrain)."""
NO_VELOCITY_CRITERIA = {"fall_rate": 0.05}
"""Tasks without a velocity command (motion tracking, pick-and-place, stand-up) bound the falls; their registration
adds its own episode metrics (`eval_criteria`, names as in eval.py's `episode_metrics`: "<term>/<name>" of a
command's, "<name>" of a metric term's)."""
LEGACY_EPISODE_METRICS_KEY = "command_metrics"
"""Where eval JSON files written before the metric terms (docs/results/*/eval_*.json) hold the command terms' metrics."""


@dataclasses.dataclass(frozen=True)
class TaskEntry:
    task: str
    kind: str
    policy: Path | None
    """The shipped policy file, or None."""
    has_height_command: bool
    eval_settings: dict
    criteria: dict
    """{metric name of scripts/eval.py's evaluate: maximum allowed}."""
    minima: dict = dataclasses.field(default_factory=dict)
    """{metric name: minimum required}."""
    ship_bar: dict = dataclasses.field(default_factory=dict)
    """What a policy trained anew must show to be shipped (the registration's `ship_bar`; empty: none)."""


def catalogue_kind(task: str) -> str:
    """One of CATALOGUE_KINDS: the task spec's kind."""
    return task_kind(task)


def has_height_command(env_cfg) -> bool:
    """Whether the task commands a base height (its base_velocity command has a height range)."""
    commands = getattr(env_cfg, "commands", None)
    command = getattr(commands, "base_velocity", None)
    return hasattr(getattr(command, "ranges", None), "base_height_m")


def task_entry(task: str) -> TaskEntry:
    """The catalogue entry of one registered task (KeyError naming the registered tasks for an unknown one)."""
    spec = task_spec(task)
    kind = catalogue_kind(task)
    height, velocity = False, True
    if kind in ("trainable", "distilled"):  # a multi-agent config has a command per agent: velocity criteria each
        env_cfg = load_cfgs(task)[0]
        height = has_height_command(env_cfg)
        velocity = getattr(getattr(env_cfg, "commands", None), "base_velocity", None) is not None
    criteria = dict(HEIGHT_CRITERIA if height else DEFAULT_CRITERIA if velocity else NO_VELOCITY_CRITERIA)
    criteria.update(spec.eval_criteria)
    settings = {**DEFAULT_EVAL_SETTINGS, **spec.eval_settings}
    evaluated = kind in EVALUATED_KINDS
    return TaskEntry(task=task, kind=kind, policy=pretrained_policy(task), has_height_command=height,
                     eval_settings=settings, criteria=criteria if evaluated else {},
                     minima=dict(spec.eval_minima) if evaluated else {}, ship_bar=dict(spec.ship_bar))


def catalogue() -> list[TaskEntry]:
    """Every registered agile task, sorted by ID."""
    return [task_entry(task) for task in registered_tasks()]


def evaluated_tasks() -> list[TaskEntry]:
    """The tasks eval_all.py evaluates: trainable, distilled or multi-agent, with a shipped policy; a second ID of one task
    (sharing its policy file, e.g. Velocity-Height-G1-v0 = -Teacher-v0) is evaluated once, under the file's name
    (a policy per motion, <task>.<motion>.pt: the task's default motion)."""
    return [e for e in catalogue()
            if e.kind in EVALUATED_KINDS and e.policy is not None and e.policy.stem.split(".")[0] == e.task]


def criterion_values(metrics: dict, name: str, breakdown: bool = True) -> list[tuple[list | None, float | None]]:
    """(bin, value) of what a criterion on `name` bounds in eval.py's metrics: with `breakdown` (a maximum) and `name`
    one of its `error_by_command` breakdowns, every bin that has steps (e.g. "height_error_m_by_height_m": each
    commanded-height band); else the one value, top-level then among `episode_metrics` (None: not measured), bin None."""
    breakdowns = metrics.get("error_by_command", {})
    if breakdown and name in breakdowns:
        return [(row["command"], row["error"]) for row in breakdowns[name] if row["steps"] > 0]
    episode_metrics = metrics.get("episode_metrics", metrics.get(LEGACY_EPISODE_METRICS_KEY, {}))
    return [(None, metrics.get(name, episode_metrics.get(name)))]


def missed_criteria(metrics: dict, criteria: dict, minima: dict | None = None) -> list[str]:
    """'metric value > maximum' (or '< minimum') for each criterion the metrics miss (`criterion_values`: a maximum on
    a breakdown bounds each of its bins); a criterion whose metric is absent is a miss too (an eval that did not
    measure it cannot pass it)."""
    missed = []
    for bounds, kind, within, sign in ((criteria, "maximum", lambda v, b: v <= b, ">"),
                                       (minima or {}, "minimum", lambda v, b: v >= b, "<")):
        for name, bound in bounds.items():
            for command, value in criterion_values(metrics, name, breakdown=kind == "maximum"):
                if value is None:
                    missed.append(f"{name} not measured ({kind} {bound})")
                elif not within(value, bound):  # NaN misses
                    label = "" if command is None else f" {_bin_label(command)}"
                    missed.append(f"{name}{label} {value:.4g} {sign} {bound:g}")
    return missed


def worst_margin(metrics: dict, criteria: dict, minima: dict | None = None) -> float:
    """How far the metrics are from their criteria, as one number: the largest of value / maximum over the maxima
    (each breakdown bin with steps, where a maximum bounds a breakdown) and of minimum / value over the minima. At most
    1 where every criterion is met (as `missed_criteria` judges); inf for a metric not measured, NaN or past a zero
    bound."""
    def ratio(numerator, denominator) -> float:
        if numerator is None or denominator is None or not numerator == numerator or not denominator == denominator:
            return math.inf
        if denominator == 0.0:
            return 0.0 if numerator == 0.0 else math.inf
        return numerator / denominator

    ratios = [ratio(value, bound) for name, bound in criteria.items() for _, value in criterion_values(metrics, name)]
    ratios += [ratio(bound, value) for name, bound in (minima or {}).items()
               for _, value in criterion_values(metrics, name, breakdown=False)]
    return max(ratios, default=0.0)


def _bin_label(command: list) -> str:
    """The label of a breakdown bin [low, high], e.g. "[0.2, 0.4)" (high None: open-ended)."""
    low, high = command
    return f"[{low:g}, {'' if high is None else f'{high:g}'})"
