"""A checkpoint remembers the overrides its run was trained with; eval, play and a resume that leave one out say so."""

from __future__ import annotations

import pytest
import torch
from commands import FLAT_GROUND_ARGS, run_command

from agile.run.task_setup import overrides_not_repeated
from agile.utils.config import configclass


@configclass
class Rewards:
    dof_vel: dict = None


@configclass
class Env:
    episode_length_s: float = 20.0
    terrain: str | None = "rough"
    rewards: Rewards = None


@configclass
class Agent:
    num_steps_per_env: int = 24


TRAINED = ["env.rewards.dof_vel.weight=-0.001", "agent.num_steps_per_env=4", "env.terrain=null"]


def configs(weight: float, terrain: str | None = None) -> dict:
    return {"env": Env(terrain=terrain, rewards=Rewards(dof_vel={"weight": weight})), "agent": Agent()}


def test_overrides_not_repeated_names_what_the_configs_here_do_not_hold():
    assert overrides_not_repeated(TRAINED, {"env": configs(-0.002)["env"]}) == \
        ["env.rewards.dof_vel.weight=-0.001 (here: -0.002)"]
    # the same value, given again or the task's default since, is no difference; the agent's only where asked
    assert overrides_not_repeated(TRAINED, {"env": configs(-1e-3)["env"]}) == []
    assert overrides_not_repeated(TRAINED, configs(-1e-3)) == ["agent.num_steps_per_env=4 (here: 24)"]
    assert overrides_not_repeated(TRAINED, {"env": configs(-1e-3, terrain="rough")["env"]}) == \
        ["env.terrain=null (here: 'rough')"]
    # the last override of a path is the one that was applied; a value of another type is a difference
    assert overrides_not_repeated(["env.episode_length_s=5.0", "env.episode_length_s=20"], configs(-1e-3)) == []
    assert overrides_not_repeated(["env.episode_length_s=long"], configs(-1e-3)) == \
        ["env.episode_length_s=long (here: 20.0)"]
    # a field the config no longer has (renamed since) is named as such
    assert overrides_not_repeated(["env.rewards.feet_air_time.weight=1.0"], configs(-1e-3)) == \
        ["env.rewards.feet_air_time.weight=1.0 (here: no such field)"]


@pytest.fixture(scope="module")
def trained_checkpoint(tmp_path_factory):
    log_root = tmp_path_factory.mktemp("logs")
    overrides = [*FLAT_GROUND_ARGS, "env.rewards.dof_vel.weight=-0.001", "agent.num_steps_per_env=4"]
    code, out, err = run_command("train", "--task", "Velocity-T1-v0", "--device", "cpu", "--num_envs", "2",
                                 "--max_iterations", "1", "--log_root", str(log_root), *overrides)
    assert code == 0, out + err
    (run_dir,) = (log_root / "velocity_t1").iterdir()
    return sorted(run_dir.glob("model_*.pt"))[-1], overrides


def test_the_checkpoint_holds_the_runs_overrides(trained_checkpoint):
    checkpoint, overrides = trained_checkpoint
    assert torch.load(checkpoint, weights_only=True)["infos"]["overrides"] == overrides


def test_eval_without_a_trained_override_says_which(trained_checkpoint):
    checkpoint, overrides = trained_checkpoint
    eval_args = ["--task", "Velocity-T1-v0", "--device", "cpu", "--num_envs", "2", "--checkpoint", str(checkpoint),
                 "--episode_length_s", "0.2"]
    code, out, err = run_command("eval", *eval_args, *FLAT_GROUND_ARGS)
    assert code == 0, out + err
    assert "trained with 1 override(s) that this command does not hold: env.rewards.dof_vel.weight=-0.001 " \
           "(here: " in out, out
    code, out, err = run_command("eval", *eval_args, *overrides)
    assert code == 0 and "does not hold" not in out, out + err


def test_a_resume_without_a_trained_override_says_which(trained_checkpoint, tmp_path):
    checkpoint, _ = trained_checkpoint
    code, out, err = run_command("train", "--task", "Velocity-T1-v0", "--device", "cpu", "--num_envs", "2",
                                 "--max_iterations", "1", "--log_root", str(tmp_path), "--resume", "--checkpoint",
                                 str(checkpoint), *FLAT_GROUND_ARGS, "agent.num_steps_per_env=4")
    assert code == 0, out + err
    assert "env.rewards.dof_vel.weight=-0.001 (here: " in out and "Add them to continue the training it was in" in out, out
