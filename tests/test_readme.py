"""The README's Python examples that run on the CPU run as written (the scene example, its env, the PettingZoo
view), each in this process."""

import re
from pathlib import Path

import pytest

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()
BLOCKS = re.findall(r"```python\n(.*?)```", README, flags=re.S)


def block_with(text: str) -> str:
    (block,) = [b for b in BLOCKS if text in b]
    return block


def test_the_scene_example_builds_an_env_that_steps(capsys):
    namespace: dict = {}
    exec(block_with("def on_a_stand"), namespace)  # noqa: S102 (the README's own code)
    exec(block_with("ManagerBasedRLEnv(ManagerBasedRLEnvCfg("), namespace)  # noqa: S102
    env = namespace["env"]
    assert set(env.scene.keys()) >= {"robot_a", "robot_b", "table", "object"}
    assert "'cube_height': 1" in capsys.readouterr().out
    env.close()


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_the_parallel_view_example_runs(capsys):
    exec(block_with("ParallelView(world)"), {})  # noqa: S102
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 8 and all("'g1'" in line and "'t1'" in line for line in out), out
