"""On the CUDA host: the captured env step behaves like the eager one (resets, logs, curricula)."""

import gymnasium as gym
import pytest
import torch

import agile.tasks  # noqa: F401

pytestmark = pytest.mark.gpu


def test_captured_step_resets_logs_and_ramps_weights():
    env = gym.make("Velocity-T1-v0", num_envs=64, device="cuda:0",
                   overrides=["episode_length_s=0.5", "curriculum.action_rate.params.start_step=0",
                              "curriculum.action_rate.params.num_steps=40"]).unwrapped
    assert env.step_is_captured
    action = torch.zeros(64, env.action_manager.total_action_dim, device="cuda:0")
    lengths = []
    for _ in range(60):
        obs, reward, terminated, truncated, extras = env.step(action)
        lengths.append(env.episode_length_buf.clone())
    assert env._captured_step.graph is not None
    assert int(env.common_step_counter) == 60
    # episodes of 25 steps: time-outs happen and reset the counters inside the graph
    assert max(int(x.max()) for x in lengths) <= 25
    assert truncated.dtype == torch.bool and torch.isfinite(reward).all()
    assert env.reward_manager.weights["action_rate"].item() == pytest.approx(-2.0)
    assert extras["log"]["Episode/length_s"].item() > 0


def test_captured_step_recovers_from_nan():
    env = gym.make("Velocity-G1-History-v0", num_envs=32, device="cuda:0").unwrapped
    action = torch.zeros(32, env.action_manager.total_action_dim, device="cuda:0")
    for _ in range(5):
        env.step(action)
    env.scene["robot"].joint_vel[3, 0] = float("nan")
    obs, reward, terminated, truncated, extras = env.step(action)
    assert terminated[3] and extras["log"]["Episode_Termination/sim_unstable"].item() > 0
    assert torch.isfinite(reward).all() and torch.isfinite(env.scene["robot"].joint_pos).all()


def smoke_tasks():
    from test_tasks_smoke import SMOKE_TASKS

    return [task for task in SMOKE_TASKS if not task.startswith("Debug-") and not task.endswith("-Debug-v0")]


@pytest.mark.parametrize("task", smoke_tasks())
def test_every_task_step_is_captured(task):
    """A term that copies from the host (a list index, torch.tensor of constants) inside the step breaks the CUDA
    graph capture, which CPU tests cannot see: each task is stepped past its capture here."""
    env = gym.make(task, num_envs=16, device="cuda:0").unwrapped
    env.reset()
    action = torch.zeros(16, env.action_manager.total_action_dim, device="cuda:0")
    for _ in range(6):
        obs, reward, terminated, truncated, extras = env.step(action)
    assert env._captured_step.graph is not None and torch.isfinite(reward).all()
