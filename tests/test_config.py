import pytest

from agile.rl_env.managers import RewTerm
from agile.utils.config import ConfigError, apply_overrides, configclass, parse_value, set_by_path, to_dict


def _double(x):
    return 2 * x


@configclass
class Inner:
    weight = 1.0
    names = [".*"]


@configclass
class Outer:
    count = 4
    flag = True
    inner = Inner()
    term = RewTerm(func=_double, weight=0.5, params={"std": 0.2})


def test_defaults_are_copied_per_instance():
    a, b = Outer(), Outer()
    a.inner.weight = 3.0
    a.inner.names.append("x")
    a.term.params["std"] = 9.0
    assert b.inner.weight == 1.0 and b.inner.names == [".*"] and b.term.params["std"] == 0.2


def test_override_sets_nested_fields_and_dict_keys():
    cfg = Outer()
    apply_overrides({"env": cfg}, ["env.inner.weight=2", "env.term.params.std=0.5", "env.count=8"])
    assert cfg.inner.weight == 2.0 and isinstance(cfg.inner.weight, float)
    assert cfg.term.params["std"] == 0.5
    assert cfg.count == 8


def test_misspelt_field_names_the_field_and_lists_valid_ones():
    with pytest.raises(ConfigError, match="has no field 'wieght'.*'weight'"):
        set_by_path(Outer(), "inner.wieght", 1.0, root_name="env")
    with pytest.raises(ConfigError, match="no key 'sdt'"):
        set_by_path(Outer(), "term.params.sdt", 1.0)


def test_wrong_type_is_rejected_with_the_field_name():
    with pytest.raises(ConfigError, match="'env.count' expects int"):
        apply_overrides({"env": Outer()}, ["env.count=abc"])
    with pytest.raises(ConfigError, match="expects a bool"):
        apply_overrides({"env": Outer()}, ["env.flag=3"])
    with pytest.raises(ConfigError, match="must start with one of"):
        apply_overrides({"env": Outer()}, ["count=3"])


def test_fields_keep_their_written_order_or_the_class_is_refused():
    # annotated fields become the dataclass's first fields; a class whose written order that would change is an
    # error (a group's term order is the observation layout, an events class's order the order of its draws)
    @configclass
    class Annotated:
        b: int = 2
        a: int = 1

    assert list(Annotated.__dataclass_fields__) == ["b", "a"]
    with pytest.raises(TypeError, match="field 'b' has a type annotation but comes after 'a'"):
        @configclass
        class Mixed:
            a = 1
            b: int = 2


@configclass
class WithOptionalGroup:
    group: Inner | None = None
    extras: dict | None = None


def test_an_unset_config_group_is_switched_on_by_a_dict_override():
    cfg = WithOptionalGroup()
    apply_overrides({"agent": cfg}, ["agent.group={}", "agent.extras={'a': 1}"])
    assert cfg.group == Inner() and cfg.extras == {"a": 1}  # the group built from its defaults; a plain dict stays
    apply_overrides({"agent": cfg}, ["agent.group=null"])
    assert cfg.group is None
    apply_overrides({"agent": cfg}, ["agent.group={'weight': 2.0}"])
    assert cfg.group.weight == 2.0 and cfg.group.names == [".*"]
    with pytest.raises(ConfigError, match=r"'agent.group' \(Inner\) has no field 'wieght'. Fields: \['weight', 'names'\]"):
        apply_overrides({"agent": WithOptionalGroup()}, ["agent.group={'wieght': 2.0}"])


def test_parse_value():
    assert parse_value("1e-3") == 1e-3
    assert parse_value("[1, 2]") == [1, 2]
    assert parse_value("true") is True
    assert parse_value("hello") == "hello"


def test_to_dict_names_functions():
    d = to_dict(Outer())
    assert d["term"]["func"].endswith(":_double")
    assert d["inner"] == {"weight": 1.0, "names": [".*"]}


def test_shipped_policy_conditions_still_name_real_fields():
    # over the conditions file as it stands (no shipped policy has conditions at present): an entry whose task has
    # no shipped policy, or whose overrides name a renamed field (ConfigError), fails here
    import agile.tasks

    for task in agile.tasks.registered_tasks():
        trained_on, overrides = agile.tasks.pretrained_policy_conditions(task)
        if not overrides:
            continue
        assert trained_on and agile.tasks.pretrained_policy(task) is not None, task
        env_cfg, agent_cfg = agile.tasks.load_cfgs(task)
        apply_overrides({"env": env_cfg, "agent": agent_cfg}, overrides)
        assert env_cfg.scene.terrain is None, task  # every shipped policy with conditions learned on flat ground


def test_shipped_policy_conditions_follow_the_policy_file(tmp_path, monkeypatch):
    import agile.tasks

    conditions = tmp_path / "conditions.yaml"
    conditions.write_text("Velocity-Height-G1-Teacher-v0:\n  trained_on: flat ground\n"
                          "  env_overrides: [env.scene.terrain=null]\n")
    monkeypatch.setattr(agile.tasks, "PRETRAINED_CONDITIONS", conditions)
    # Velocity-Height-G1-v0 runs the policy shipped as Velocity-Height-G1-Teacher-v0, so its conditions too
    assert (agile.tasks.pretrained_policy_conditions("Velocity-Height-G1-v0")
            == agile.tasks.pretrained_policy_conditions("Velocity-Height-G1-Teacher-v0")
            == ("flat ground", ["env.scene.terrain=null"]))
    assert agile.tasks.pretrained_policy_conditions("Velocity-T1-v0") == ("", [])


@pytest.mark.parametrize("task", ["Velocity-T1-v0", "Velocity-G1-History-v0", "Velocity-Height-G1-Teacher-v0",
                                  "Velocity-Height-G1-Student-Recurrent-v0", "Velocity-Height-G1-Student-History-v0"])
def test_a_policy_trained_on_the_registered_task_has_no_conditions(task):
    import agile.tasks

    assert agile.tasks.pretrained_policy(task) is not None
    assert agile.tasks.pretrained_policy_conditions(task) == ("", [])


def test_rsl_rl_runner_options_reach_the_runner_cfg():
    import agile.tasks
    from agile.rl import to_rsl_rl_dict

    _, agent_cfg = agile.tasks.load_cfgs("Velocity-T1-v0")
    assert to_rsl_rl_dict(agent_cfg)["check_for_nan"] is True
    apply_overrides({"agent": agent_cfg}, ["agent.check_for_nan=false", "agent.torch_compile_mode=default"])
    train_cfg = to_rsl_rl_dict(agent_cfg)
    assert train_cfg["check_for_nan"] is False and train_cfg["torch_compile_mode"] == "default"
    assert train_cfg["actor"]["distribution_cfg"]["init_std"] == 0.3  # T1 starts with 0.3 rad of action noise


def test_the_float32_matmul_precision_is_a_runner_setting_applied_to_the_process():
    import torch

    import agile.tasks
    from agile.rl import to_rsl_rl_dict
    from agile.rl.configs import set_matmul_precision

    _, agent_cfg = agile.tasks.load_cfgs("Velocity-G1-History-v0")
    assert agent_cfg.float32_matmul_precision == "highest"
    assert "float32_matmul_precision" not in to_rsl_rl_dict(agent_cfg)  # ours, not rsl-rl's
    apply_overrides({"agent": agent_cfg}, ["agent.float32_matmul_precision=tf32"])
    with pytest.raises(ConfigError, match=r"float32_matmul_precision: 'tf32' is not one of \('highest', 'high'"):
        to_rsl_rl_dict(agent_cfg)
    before = torch.get_float32_matmul_precision()
    try:
        apply_overrides({"agent": agent_cfg}, ["agent.float32_matmul_precision=high"])
        set_matmul_precision(agent_cfg)
        assert torch.get_float32_matmul_precision() == "high"
    finally:
        torch.set_float32_matmul_precision(before)


@pytest.mark.parametrize("task", ["Velocity-T1-v0", "Velocity-G1-History-v0", "Velocity-Height-G1-Teacher-v0",
                                  "Velocity-Height-G1-Student-Recurrent-v0", "Velocity-Height-G1-Student-History-v0"])
def test_velocity_tasks_start_on_agile_terrain_rows(task):
    import agile.tasks

    env_cfg, _ = agile.tasks.load_cfgs(task)
    assert env_cfg.scene.max_init_terrain_level == 1  # AGILE's velocity configs start every env on row 0 or 1


def test_inference_cfg_removes_exactly_the_training_only_action_terms():
    """Play, eval and export run without the aids (lift, harness, random arm motions) and with every other term;
    the same rule as a built env's `ActionManager.training_only_terms`."""
    import dataclasses

    import agile.tasks
    from agile.rl_env.managers import is_training_only
    from agile.run.policy import inference_cfg

    removed_by_task = {}
    for task in agile.tasks.registered_tasks():
        env_cfg, _ = agile.tasks.load_cfgs(task)
        if not hasattr(env_cfg, "actions"):  # a multi-agent task: its agents' configs go through inference_cfg
            assert all(hasattr(agent_cfg, "actions") for agent_cfg in env_cfg.agents.values()), task
            continue
        before = {f.name: getattr(env_cfg.actions, f.name) for f in dataclasses.fields(env_cfg.actions)}
        after = inference_cfg(env_cfg).actions
        removed = sorted(name for name, term in before.items() if term is not None and getattr(after, name) is None)
        assert removed == sorted(name for name, term in before.items() if is_training_only(term)), task
        assert all(getattr(after, name) is term for name, term in before.items() if name not in removed), task
        assert env_cfg.curriculum is None, task
        removed_by_task[task] = removed
    assert removed_by_task["StandUp-T1-v0"] == ["lift"]
    assert removed_by_task["HeightTracking-G1-v0"] == ["lift"]
    assert "harness" in removed_by_task["Velocity-Height-G1-Teacher-v0"]
    assert removed_by_task["Velocity-T1-v0"] == []


def test_registering_the_tasks_imports_no_simulator():
    """`import agile.tasks` registers every task by entry-point strings: a fresh interpreter answers `agile list`'s
    registry questions without importing Newton, Warp or the env (they cost ~7 s)."""
    import subprocess
    import sys

    code = ("import sys, agile.tasks; heavy = sorted(m for m in ('newton', 'warp', 'agile.rl_env.env', 'agile.sim') "
            "if m in sys.modules); print(len(agile.tasks.registered_tasks())); assert not heavy, heavy")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    assert int(result.stdout.split()[-1]) > 10
