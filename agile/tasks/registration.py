"""One way to register an agile task with gymnasium, and the typed spec registered with it."""

from __future__ import annotations

import dataclasses
import numbers

import gymnasium as gym

from agile.errors import AgileError

SINGLE_AGENT_ENV = "agile.rl_env.env:ManagerBasedRLEnv"
MULTI_AGENT_ENV = "agile.marl.env:MultiAgentEnv"
TASK_KINDS = ("trainable", "distilled", "debug", "multi_agent", "record")
"""trainable: trained by PPO on its own reward; distilled: a student learning from a teacher's policy (its agent config
is a DistillationRunnerCfg naming the teacher task); debug: run by hand in the browser GUI; multi_agent: a world of several agents (a `MultiAgentEnv`); record: records demonstrations with
another task's policy (`agile record`)."""
EVAL_SETTING_NAMES = ("num_envs", "num_episodes", "episode_length_s", "overrides")
SHIP_BAR_FIELDS = ("mean_terrain_level", "fall_rate", "all_rows_fall_rate")
"""A ship bar: the training's mean terrain level at the checkpoint (a minimum), the falls per episode on the start
rows and with spawns over every terrain row (maxima)."""
SPEC_KWARG = "task_spec"
"""The registration kwarg that holds a task's `TaskSpec` (gymnasium passes it to the env, which ignores it)."""


class TaskSpecError(AgileError, ValueError):
    """A registration's field that does not exist or holds a value of the wrong kind."""


@dataclasses.dataclass(frozen=True)
class TaskSpec:
    """What agile knows of a registered task besides its configs. Frozen: read with attributes, set at registration."""

    task: str
    env_cfg_entry_point: str
    """"module:attribute" of the env config class (or function)."""
    runner_cfg_entry_point: str
    """"module:attribute" of the runner (agent) config function."""
    kind: str = "trainable"
    """One of TASK_KINDS."""
    shipped_policy: str | None = None
    """The name of the shipped policy file (agile/data/policy/<name>.pt) when it is not the task's own ID: two IDs
    of one task share one policy."""
    shipped_policy_per: str | None = None
    """A config field (e.g. "commands.motion.motion_file") with one shipped policy per value: <name>.<value>.pt."""
    eval_criteria: dict = dataclasses.field(default_factory=dict)
    """{metric: maximum} the shipped policy must meet (added to the catalogue's defaults for the task)."""
    eval_minima: dict = dataclasses.field(default_factory=dict)
    """{metric: minimum} (shares of success, such as a cube lifted)."""
    eval_settings: dict = dataclasses.field(default_factory=dict)
    """How eval_all evaluates the shipped policy: any of EVAL_SETTING_NAMES (the catalogue's defaults otherwise)."""
    ship_bar: dict = dataclasses.field(default_factory=dict)
    """What a policy trained anew must show to be shipped (`agile time_to_policy --target shippable`), every one of
    SHIP_BAR_FIELDS; empty: the task has none."""
    startup_dataset: str | None = None
    """"module:function" that has the env collect the dataset it builds at its start anew instead of loading the disk
    cache (`function(env_cfg)`; the commands' --no_cache); None: the task builds no dataset at its start."""
    trainer_cfgs: dict = dataclasses.field(default_factory=dict)
    """{trainer: "module:function" of its config}, the trainers besides RSL-RL the task trains with
    (`agile train --trainer`, e.g. "happo" for a multi-agent task)."""
    single_agent_baselines: dict = dataclasses.field(default_factory=dict)
    """Multi-agent tasks: {agent group: (single-robot task, its overrides)} the benchmark compares the world with."""
    robot_type: str | None = None
    """Recording tasks: the robot's name in the LeRobot dataset."""
    task_description: str | None = None
    """Recording tasks: the dataset's task text (default: the task ID)."""
    color_palettes: dict = dataclasses.field(default_factory=dict)
    """Recording tasks: {object: "module:attribute" of its colour palette} drawn from per episode."""

    def __post_init__(self):
        if self.kind not in TASK_KINDS:
            raise TaskSpecError(f"task {self.task}: kind must be one of {', '.join(TASK_KINDS)}, got {self.kind!r}")
        for name in ("eval_criteria", "eval_minima"):
            for metric, bound in getattr(self, name).items():
                if not isinstance(bound, numbers.Real):
                    raise TaskSpecError(f"task {self.task}: {name}[{metric!r}] must be a number, got {bound!r}")
        if self.ship_bar and (set(self.ship_bar) != set(SHIP_BAR_FIELDS)
                              or not all(isinstance(v, numbers.Real) for v in self.ship_bar.values())):
            raise TaskSpecError(f"task {self.task}: ship_bar holds a number for each of {', '.join(SHIP_BAR_FIELDS)}, "
                                f"got {self.ship_bar!r}")
        unknown = sorted(set(self.eval_settings) - set(EVAL_SETTING_NAMES))
        if unknown:
            raise TaskSpecError(f"task {self.task}: eval_settings has no field {', '.join(unknown)}; its fields: "
                                f"{', '.join(EVAL_SETTING_NAMES)}")
        for trainer, entry_point in self.trainer_cfgs.items():
            if not isinstance(entry_point, str) or ":" not in entry_point:
                raise TaskSpecError(f"task {self.task}: trainer_cfgs[{trainer!r}] must be a 'module:function' string, "
                                    f"got {entry_point!r}")
        for name in ("shipped_policy", "shipped_policy_per", "startup_dataset", "robot_type", "task_description"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, str):
                raise TaskSpecError(f"task {self.task}: {name} must be a string, got {value!r}")

    @property
    def policy_name(self) -> str:
        """The shipped policy's file name, without .pt (and without the per-value suffix)."""
        return self.shipped_policy or self.task


SPEC_FIELDS = tuple(f.name for f in dataclasses.fields(TaskSpec) if f.name not in
                    ("task", "env_cfg_entry_point", "runner_cfg_entry_point"))
"""The fields a registration may set."""


def task_spec_of(task_id: str, env_cfg: str, runner_cfg: str, fields: dict) -> TaskSpec:
    """The spec of a registration; TaskSpecError naming the valid fields for one that does not exist."""
    unknown = sorted(set(fields) - set(SPEC_FIELDS))
    if unknown:
        raise TaskSpecError(f"task {task_id}: no task spec field {', '.join(unknown)}; the fields: "
                            f"{', '.join(SPEC_FIELDS)}")
    return TaskSpec(task=task_id, env_cfg_entry_point=env_cfg, runner_cfg_entry_point=runner_cfg, **fields)


def register_task(task_id: str, env_cfg: str, runner_cfg: str, env_class: str = SINGLE_AGENT_ENV, **fields) -> None:
    """Register `task_id`: `env_cfg` and `runner_cfg` are "module:attribute" entry points of its env config class
    and its runner config function; `fields` are its `TaskSpec`'s (e.g. `kind`, `shipped_policy`), checked here."""
    spec = task_spec_of(task_id, env_cfg, runner_cfg, fields)
    gym.register(id=task_id, entry_point=env_class, disable_env_checker=True, order_enforce=False,
                 kwargs={"task_name": task_id, "env_cfg_entry_point": env_cfg, "rsl_rl_cfg_entry_point": runner_cfg,
                         SPEC_KWARG: spec})
