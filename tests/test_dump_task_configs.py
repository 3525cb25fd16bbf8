"""scripts/dump_task_configs.py: a task's env and agent configs dumped as train writes them, two dumps compared field
by field (a changed value, a missing file), exit codes 0 / 1 / 2."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest
import yaml

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "dump_task_configs.py"
spec = importlib.util.spec_from_file_location("dump_task_configs", SCRIPT)
dump_task_configs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(dump_task_configs)

TASK = "Velocity-T1-v0"


@pytest.fixture(scope="module")
def dumps(tmp_path_factory):
    before, after = tmp_path_factory.mktemp("before"), tmp_path_factory.mktemp("after")
    for folder in (before, after):
        assert dump_task_configs.dump_task_configs(out_dir=folder, tasks=[TASK]) == [TASK]
    return before, after


def test_a_dump_is_what_train_writes(dumps):
    from agile.tasks import load_cfgs
    from agile.utils.config import to_dict

    env_cfg, agent_cfg = load_cfgs(TASK)
    before, _ = dumps
    assert yaml.safe_load((before / TASK / "env.yaml").read_text()) == yaml.safe_load(
        yaml.safe_dump(to_dict(env_cfg), sort_keys=False))
    assert yaml.safe_load((before / TASK / "agent.yaml").read_text())["seed"] == agent_cfg.seed


def test_two_dumps_of_one_code_are_identical_and_a_change_is_named(dumps, tmp_path):
    before, after = dumps
    assert dump_task_configs.compare_dumps(before_dir=before, after_dir=after) == []
    assert dump_task_configs.main(["compare", str(before), str(after)]) == 0
    changed = tmp_path / "changed"
    (changed / TASK).mkdir(parents=True)
    agent = yaml.safe_load((after / TASK / "agent.yaml").read_text())
    agent["algorithm"]["gamma"] = 0.5
    (changed / TASK / "agent.yaml").write_text(yaml.safe_dump(agent, sort_keys=False))
    found = dump_task_configs.compare_dumps(before_dir=before, after_dir=changed)
    assert (TASK, "agent.yaml", "algorithm.gamma", 0.99, 0.5) in found
    assert (TASK, "env.yaml", "", "present", "absent") in found
    assert dump_task_configs.main(["compare", str(before), str(changed)]) == 1


def test_an_unknown_task_is_refused_naming_the_registered_ones(tmp_path, capsys):
    assert dump_task_configs.main(["dump", str(tmp_path), "--tasks", "Velocity-T9-v0"]) == 2
    assert "unknown tasks ['Velocity-T9-v0']" in capsys.readouterr().err
