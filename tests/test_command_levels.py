"""The velocity command-range curriculum (opt-in, not AGILE's): off it touches nothing; on, the ranges start narrow and
widen only at checked steps where the ending episodes tracked every named reward well."""

import gymnasium as gym
import pytest
import torch

from commands import FLAT_GROUND

import agile.tasks  # noqa: F401

ON = ["env.curriculum.command_levels.params.start_fraction=0.3", "env.curriculum.command_levels.params.interval_steps=5"]


def make(*overrides):
    return gym.make("Velocity-T1-v0", num_envs=4, device="cpu", seed=0,
                    overrides=[*FLAT_GROUND, *overrides]).unwrapped


def test_off_by_default_the_configured_ranges_stay():
    env = make()
    try:
        command = env.command_manager.get_term("base_velocity")
        term = env.curriculum_manager.funcs["command_levels"]
        assert not term.active
        assert command.high.tolist() == pytest.approx([0.5, 0.5, 1.0])  # T1's configured ranges
        for _ in range(6):
            env.step(torch.zeros(4, env.action_manager.total_action_dim))
        assert command.high.tolist() == pytest.approx([0.5, 0.5, 1.0]) and term.fraction.item() == 1.0
    finally:
        env.close()


def test_the_ranges_widen_at_checked_steps_where_the_ending_episodes_tracked_well():
    env = make(*ON)
    try:
        command = env.command_manager.get_term("base_velocity")
        term = env.curriculum_manager.funcs["command_levels"]
        assert command.high.tolist() == pytest.approx([0.15, 0.15, 0.3])  # 0.3 of the configured ranges
        params = env.cfg.curriculum.command_levels.params
        rewards = env.reward_manager
        env.episode_length_buf.fill_(100)  # 2 s episodes
        ending = torch.tensor([True, True, False, False])

        def call(step: int, kernel_mean: list[float]) -> float:
            env.common_step_counter.fill_(step)
            for name in params["reward_names"]:
                rewards.episode_sums[name].copy_(torch.tensor(kernel_mean) * rewards.weights[name] * 2.0)
            return term(env, ending, **params).item()

        assert call(7, [0.9, 0.9, 0.0, 0.0]) == pytest.approx(0.3)  # tracked well, but not a checked step
        assert call(10, [0.6, 0.2, 0.9, 0.9]) == pytest.approx(0.3)  # the ending episodes' mean 0.4 < 0.5 (the
        # other envs' sums do not count); 0.55 > 0.5 for both rewards: widened by 0.1
        assert call(10, [0.9, 0.2, 0.0, 0.0]) == pytest.approx(0.4)
        assert command.high.tolist() == pytest.approx([0.2, 0.2, 0.4])
        assert command.low.tolist() == pytest.approx([-0.2, -0.2, -0.4])
        rewards.episode_sums["track_ang_vel"].zero_()  # yaw not tracked: no widening
        env.common_step_counter.fill_(15)
        assert term(env, ending, **params).item() == pytest.approx(0.4)
        for step in range(20, 200, 5):
            call(step, [0.9, 0.9, 0.9, 0.9])
        assert term.fraction.item() == 1.0 and command.high.tolist() == pytest.approx([0.5, 0.5, 1.0])
        assert "command_levels.fraction" in env.curriculum_manager.training_state()  # kept by a resume
    finally:
        env.close()


@pytest.mark.parametrize(("override", "message"), [
    ("env.curriculum.command_levels.params.start_fraction=0.0", "start_fraction must be within"),
    ("env.curriculum.command_levels.params.threshold=1.5", "threshold must be within"),
    ("env.curriculum.command_levels.params.reward_names=['track_yaw']", "no reward term 'track_yaw'"),
])
def test_bad_settings_are_refused_naming_them(override, message):
    with pytest.raises(Exception, match=message):
        make(*ON, override)
