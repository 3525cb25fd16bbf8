"""The typed task spec: registered with each gym ID, read with attributes, checked at registration."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import pytest

import agile.tasks
from agile.errors import AgileError
from agile.tasks.registration import SPEC_FIELDS, TaskSpec, TaskSpecError, register_task

ENTRY_POINTS = ("agile.tasks.velocity.t1.velocity_env_cfg:T1VelocityEnvCfg",
                "agile.tasks.velocity.t1.agents.rsl_rl_cfg:t1_velocity_ppo_runner_cfg")


def test_every_registered_task_has_a_spec():
    """(test_cli's catalogue test holds each spec's kind to its agent config: distilled where it is a
    DistillationRunnerCfg)"""
    for task in agile.tasks.registered_tasks():
        spec = agile.tasks.task_spec(task)
        assert isinstance(spec, TaskSpec) and spec.task == task
    assert agile.tasks.task_spec("StandUp-T1-v0").startup_dataset == "agile.tasks.stand_up.fallen_states.startup:collect_fallen_states_anew"
    assert agile.tasks.task_spec("Velocity-T1-v0").startup_dataset is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        agile.tasks.task_spec("Velocity-T1-v0").kind = "debug"


def test_an_unknown_or_misspelt_field_is_refused_at_registration_naming_the_valid_ones():
    with pytest.raises(TaskSpecError) as refused:
        register_task("Spec-Test-v0", *ENTRY_POINTS, shiped_policy="Velocity-T1-v0")
    assert "no task spec field shiped_policy" in str(refused.value)
    assert all(name in str(refused.value) for name in SPEC_FIELDS)
    assert "Spec-Test-v0" not in gym.registry  # nothing registered
    with pytest.raises(TaskSpecError, match="kind must be one of trainable, distilled, debug, multi_agent, record"):
        register_task("Spec-Test-v0", *ENTRY_POINTS, kind="teacher")
    with pytest.raises(TaskSpecError, match="eval_settings has no field num_env; its fields: num_envs, num_episodes"):
        register_task("Spec-Test-v0", *ENTRY_POINTS, eval_settings={"num_env": 8})
    with pytest.raises(TaskSpecError, match=r"eval_criteria\['fall_rate'\] must be a number"):
        register_task("Spec-Test-v0", *ENTRY_POINTS, eval_criteria={"fall_rate": "low"})
    assert issubclass(TaskSpecError, AgileError)


def test_an_unknown_task_is_an_agile_error_and_a_key_error_naming_the_registered_ones():
    with pytest.raises(AgileError) as refused:
        agile.tasks.task_spec("Velocity-Nope-v0")
    assert isinstance(refused.value, KeyError) and str(refused.value).startswith("unknown task 'Velocity-Nope-v0'")
    assert "Velocity-T1-v0" in str(refused.value)


def test_each_kind_runs_every_command_through_one_table():
    from agile.run.task_kinds import COMMANDS, MULTI_AGENT, RUNTIMES, SINGLE_AGENT, task_runtime

    for runtime in (SINGLE_AGENT, *RUNTIMES.values()):
        assert all(callable(runtime.function(command)) for command in COMMANDS)
    kinds = {task: agile.tasks.task_kind(task) for task in agile.tasks.registered_tasks()}
    assert {task_runtime(task) for task, kind in kinds.items() if kind == "multi_agent"} == {MULTI_AGENT}
    assert {task_runtime(task) for task, kind in kinds.items() if kind != "multi_agent"} == {SINGLE_AGENT}
