"""HAPPO through harl-aht (agile.marl.harl): the factor and advantage math by hand, HARL's factor-weighted surrogate,
and the command: train the multi-rate world 2 iterations on CPU, reload the checkpoint, evaluate, refuse bad input."""

import importlib
import json
import math

import gymnasium as gym
import numpy as np
import pytest
import torch

import agile.tasks  # noqa: F401
from agile.marl.harl import HappoCfg, build_learners, harl_args, next_agent_factor, team_advantages

TASK = "MultiRate-G1-T1-Velocity-v0"


def test_next_agent_factor_multiplies_the_ratio_where_the_agent_acted():
    factor = torch.tensor([[1.0], [2.0], [1.0]])
    active = torch.tensor([True, False, True])
    before = torch.zeros(3, 2)
    after = torch.tensor([[0.1, 0.2], [5.0, 5.0], [-0.3, 0.0]])  # (B, A): the ratio is the product over A
    expected = torch.tensor([[math.exp(0.3)], [2.0], [math.exp(-0.3)]])  # row 1 did not act: unchanged
    torch.testing.assert_close(next_agent_factor(factor, active, before, after), expected)


def test_team_advantages_by_hand():
    rewards, values = torch.tensor([[1.0], [2.0]]), torch.tensor([[0.5], [1.0]])
    gamma, lam = 0.9, 0.5
    # the episode ends after slot 1: delta_1 = 2 - 1 = 1; delta_0 = 1 + 0.9 * 1 - 0.5 = 1.4; A_0 = 1.4 + 0.45 * 1
    advantages, returns = team_advantages(rewards, values, torch.tensor([[False], [True]]), torch.tensor([3.0]),
                                          gamma, lam)
    torch.testing.assert_close(advantages, torch.tensor([[1.85], [1.0]]))
    torch.testing.assert_close(returns, torch.tensor([[2.35], [2.0]]))
    # no end: delta_1 = 2 + 0.9 * 3 - 1 = 3.7; A_0 = 1.4 + 0.45 * 3.7
    advantages, _ = team_advantages(rewards, values, torch.tensor([[False], [False]]), torch.tensor([3.0]), gamma, lam)
    torch.testing.assert_close(advantages, torch.tensor([[1.4 + 0.45 * 3.7], [3.7]]))


def test_harl_surrogate_weights_the_advantage_by_the_factor():
    class OneAgentSpaces:  # what build_learners reads of a view
        agent_names = ["a"]
        observation_spaces = {"a": gym.spaces.Box(-np.inf, np.inf, (3,), np.float32)}
        action_spaces = {"a": gym.spaces.Box(-np.inf, np.inf, (2,), np.float32)}
        state_space = gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)

    torch.manual_seed(0)
    args = harl_args(HappoCfg(hidden_dims=[8], entropy_coef=0.0))
    actors, _ = build_learners(OneAgentSpaces(), args, "cpu")
    actor = actors["a"]
    obs, rnn, ones = torch.randn(2, 3), torch.zeros(2, 1, 8), torch.ones(2, 1)
    with torch.no_grad():
        actions, log_prob, _ = actor.get_actions(obs, rnn, ones)
    factor, advantage = torch.tensor([[2.0], [0.5]]), torch.tensor([[1.0], [-2.0]])
    loss, _, _, ratio = actor.update((obs, rnn, actions, ones, ones, log_prob, advantage, None, factor))
    # the behaviour policy is the current one: ratio 1, loss -mean(factor * advantage) = -(2 * 1 + 0.5 * -2) / 2
    torch.testing.assert_close(ratio.detach(), torch.ones(2, 1))
    assert float(loss.detach()) == pytest.approx(-0.5, abs=1e-6)


def run(capsys, command, *args):
    """(exit code, stdout, stderr) of `agile <command> ... --device cpu`, in this process."""
    code = 0
    try:
        code = importlib.import_module(f"agile.run.{command}").main([*args, "--device", "cpu"])
    except SystemExit as exit_info:
        code = exit_info.code
    out, err = capsys.readouterr()
    return code or 0, out, err


def test_train_reload_and_evaluate_happo_on_the_multi_rate_world(tmp_path, capsys):
    from agile.marl.happo_runner import HappoRunner
    from agile.run.happo import newest_checkpoint

    code, out, err = run(capsys, "train", "--task", TASK, "--trainer", "happo", "--num_envs", "2", "--max_iterations",
                         "2", "--log_root", str(tmp_path), "agent.rollout_s=0.08", "agent.num_mini_batches=2")
    assert code == 0, out + err
    run_dir = next((tmp_path / "multi_rate_g1_t1_velocity_happo").iterdir())
    assert (run_dir / "happo_0.pt").is_file() and newest_checkpoint(str(run_dir)) == str(run_dir / "happo_1.pt")
    iterations = [json.loads(line) for line in (run_dir / "happo_iterations.jsonl").read_text().splitlines()]
    assert [i["iteration"] for i in iterations] == [0, 1] and all(i["env_steps_per_s"] > 0 for i in iterations)
    assert "happo iteration 1" in out

    contents = torch.load(run_dir / "happo_1.pt", weights_only=True)
    # the run's wall time since its start, as agile's PPO checkpoints record it, later in the later checkpoint
    first_wall_s = torch.load(run_dir / "happo_0.pt", weights_only=True)["infos"]["wall_s"]
    assert 0 < first_wall_s < contents["infos"]["wall_s"] < 600
    world = gym.make(TASK, num_envs=2, device="cpu", seed=1).unwrapped
    runner = HappoRunner(world, HappoCfg(**contents["cfg"]), None, "cpu")
    runner.load(contents)
    for name, actor in runner.actors.items():
        for key, value in contents["actors"][name]["model"].items():
            torch.testing.assert_close(actor.actor.state_dict()[key], value)
    assert runner.current_learning_iteration == 2
    rollout = runner.collect()
    t1_active = rollout["agents"]["t1"]["active"]  # (slots, envs): the 25 Hz T1 acts at every other 50 Hz slot
    assert not t1_active[1::2].any() and rollout["agents"]["g1"]["active"].shape == t1_active.shape
    assert t1_active[0].all()
    world.close()

    code, out, err = run(capsys, "eval", "--task", TASK, "--checkpoint", str(run_dir), "--num_envs", "2",
                         "--episode_length_s", "0.4", "--out", str(tmp_path / "eval.json"))
    assert code == 0, out + err
    metrics = json.loads((tmp_path / "eval.json").read_text())
    assert metrics["checkpoints"] == {"happo": str(run_dir / "happo_1.pt")}
    assert metrics["agents"]["t1"]["control_hz"] == 25.0 and metrics["agents"]["g1"]["episodes"] == 2


@pytest.mark.parametrize("args, message", [
    (["--task", "Velocity-T1-v0"], "error: --trainer happo: needs a multi-agent task; Velocity-T1-v0 is trainable"),
    (["--task", TASK, "--resume"], "error: --trainer happo trains a new run"),
    (["--task", TASK, "agent.critic_group=nothing"],
     "error: agent.critic_group=nothing: agent 'g1' has no such observation group; its groups: policy, critic"),
])
def test_happo_refuses_what_it_cannot_train_in_one_line(capsys, args, message):
    code, out, err = run(capsys, "train", *args, "--trainer", "happo")
    assert code == 2 and err.startswith(message) and err.count("\n") == 1, err
    assert "building" not in out  # refused before the world is built
