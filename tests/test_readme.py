"""The Python examples of the README and the docs run as written on the CPU, each in this process: the README's
quick start, the how-to's scene and env (docs/howto/add_task.md), the PettingZoo view (docs/howto/multi_agent.md)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def blocks(page: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", (ROOT / page).read_text(), flags=re.S)


def block_with(page: str, text: str) -> str:
    (block,) = [b for b in blocks(page) if text in b]
    return block


def test_the_readme_quick_start_steps_a_task_on_the_cpu(capsys):
    (block,) = blocks("README.md")
    assert 'device="cpu"' in block
    exec(block, {})  # noqa: S102 (the README's own code)
    out = capsys.readouterr().out
    assert "'base_ang_vel'" in out and "torch.Size([4, 70])" in out and "torch.Size([4, 23])" in out, out


def test_the_scene_example_builds_an_env_that_steps(capsys):
    namespace: dict = {}
    exec(block_with("docs/howto/add_task.md", "def on_a_stand"), namespace)  # noqa: S102
    exec(block_with("docs/howto/add_task.md", "ManagerBasedRLEnv(ManagerBasedRLEnvCfg("), namespace)  # noqa: S102
    env = namespace["env"]
    assert set(env.scene.keys()) >= {"robot_a", "robot_b", "table", "object"}
    assert "'cube_height': 1" in capsys.readouterr().out
    env.close()


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_the_parallel_view_example_runs(capsys):
    exec(block_with("docs/howto/multi_agent.md", "ParallelView(world)"), {})  # noqa: S102
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 8 and all("'g1'" in line and "'t1'" in line for line in out), out
