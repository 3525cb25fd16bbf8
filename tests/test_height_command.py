"""HeightTracking-G1's height command (`SmoothHeightCommand`) in the built task (CPU, 3 envs): its range, shares, ramps
and settle time; the error that the metric and evaluation's bins share; the draws weighted by the bands' errors;
config errors that name the field."""

from __future__ import annotations

import dataclasses

import pytest
import torch


@pytest.fixture
def env_and_agent(height_tracking_env_and_agent):
    return height_tracking_env_and_agent


def drawn_heights(command, resamplings: int) -> torch.Tensor:
    """The heights of `resamplings` resamplings of every env (seeded)."""
    everyone = torch.ones(command.env.num_envs, dtype=torch.bool)
    torch.manual_seed(0)
    draws = []
    for _ in range(resamplings):
        command._resample(everyone)
        draws.append(command.drawn_height_m.clone())
    return torch.cat(draws)


def test_command_range_shares_and_settle_time(env_and_agent):
    env, _ = env_and_agent
    command = env.command_manager.get_term("height")
    low_m, high_m = command.cfg.ranges.height_m
    assert (low_m, high_m) == pytest.approx((-0.5, 0.92))
    draws = drawn_heights(command, 2000)
    assert draws.min().item() >= low_m - 1e-6 and draws.max().item() <= high_m + 1e-6
    # 30% stand (the top), 20% lie (the bottom), the rest uniform in between: 6000 draws, ±3 standard errors
    assert (draws == high_m).float().mean().item() == pytest.approx(0.3, abs=0.02)
    assert (draws == low_m).float().mean().item() == pytest.approx(0.2, abs=0.02)
    # ramps at 0.1-2 m/s (AGILE jumps): each update moves the command by at most speed x 0.02 s towards the draw
    assert command.cfg.ramp_speed_range_mps == pytest.approx((0.1, 2.0))
    speeds = command.ramp_speed_mps
    assert ((speeds >= 0.1) & (speeds <= 2.0)).all()
    before = command.target_height_m.clone()
    command._update_command()
    moved = (command.target_height_m - before).abs()
    gap_before = (command.drawn_height_m - before).abs()
    assert torch.allclose(moved, torch.minimum(gap_before, speeds * env.step_dt), atol=1e-6)
    # settle: 2 s = 100 env steps after a resampling before tracking counts
    assert command.settle_steps == 100
    command.steps_since_resample.fill_(100)
    assert not command.settled.any()
    command.steps_since_resample.fill_(101)
    assert command.settled.all()
    # relaxation intensity: 0 at and above 0, 1 at the bottom
    command.target_height_m[:] = torch.tensor([0.3, -0.25, -0.5])
    assert command.relaxation_intensity.tolist() == pytest.approx([0.0, 0.5, 1.0])
    env.reset()


def test_the_command_error_eval_bins_is_the_metrics_error_on_the_steps_it_counts(env_and_agent):
    from agile.run.metric_breakdowns import ErrorByCommand

    env, _ = env_and_agent
    command = env.command_manager.get_term("height")
    command.target_height_m[:] = torch.tensor([0.5, -0.2, 0.5])  # env 1 asked to relax: no height to reach
    command.steps_since_resample[:] = torch.tensor([101, 101, 0])  # env 2 not settled yet
    sample = command.command_error()
    assert (sample.error_name, sample.command_name) == ("height_error_m", "height_m")
    torch.testing.assert_close(sample.error, (command.measured_height_m - command.target_height_m).abs())
    torch.testing.assert_close(sample.measured, command.measured_height_m)
    assert sample.counted.tolist() == [True, False, False]
    by_height = ErrorByCommand(sample.bin_edges, "cpu")
    by_height.add(sample.commanded, sample.error, sample.counted.float())
    rows = by_height.rows()
    assert [row["command"] for row in rows] == [[0.4, 0.6]] and rows[0]["steps"] == 1
    assert rows[0]["error"] == pytest.approx(float(sample.error[0]))
    env.reset()


def test_error_weighted_bands_draw_more_where_the_tracking_is_worst(env_and_agent):
    env, _ = env_and_agent
    from agile.rl_env import mdp

    registered = env.command_manager.get_term("height").cfg
    assert registered.error_weighted_bands == 0  # AGILE's uniform draws as registered
    command = mdp.SmoothHeightCommand(dataclasses.replace(registered, error_weighted_bands=4), env)
    assert command.band_edges_m.tolist() == pytest.approx([0.0, 0.23, 0.46, 0.69, 0.92])
    # one step: envs settled at 0.1 m (error 0.2), 0.5 m (error 0.04, and a non-finite one that must not count),
    # one not settled at 0.8 m; the fourth band sees none and keeps its value
    command.target_height_m[:] = torch.tensor([0.1, 0.5, 0.8])
    command._update_band_errors(torch.tensor([0.2, 0.04, 0.9]), torch.tensor([True, True, False]))
    alpha = registered.band_error_ema_alpha
    assert command.band_error_ema_m.tolist() == pytest.approx(
        [(1 - alpha) * 0.1 + alpha * 0.2, 0.1, (1 - alpha) * 0.1 + alpha * 0.04, 0.1])
    command.target_height_m[:] = torch.tensor([0.5, 0.5, 0.8])
    command._update_band_errors(torch.tensor([float("nan"), 0.04, 0.9]), torch.tensor([True, True, False]))
    assert torch.isfinite(command.band_error_ema_m).all()
    # draws: the band with the largest error most often; relaxation draws keep AGILE's share
    command.band_error_ema_m[:] = torch.tensor([0.01, 0.01, 0.5, 0.01])
    probabilities = command.band_probabilities()
    assert probabilities.sum().item() == pytest.approx(1.0) and probabilities[2].item() == pytest.approx(0.597, abs=1e-3)
    draws = drawn_heights(command, 3000)
    between = draws[(draws != registered.ranges.height_m[0]) & (draws != registered.ranges.height_m[1])]
    non_negative = between[between >= 0.0]
    in_third = ((non_negative >= 0.46) & (non_negative < 0.69)).float().mean().item()
    assert in_third == pytest.approx(0.597, abs=0.04)
    assert (between < 0.0).float().mean().item() == pytest.approx(0.5 / 1.42, abs=0.04)
    for bad, field in ((dict(error_weighted_bands=-1), "error_weighted_bands"),
                       (dict(error_weighted_bands=4, band_error_ema_alpha=0.0), "band_error_ema_alpha")):
        with pytest.raises(ValueError, match=field):
            mdp.SmoothHeightCommand(dataclasses.replace(registered, **bad), env)


def test_command_config_errors_name_the_field(env_and_agent):
    env, _ = env_and_agent
    from agile.rl_env import mdp

    for bad, field in ((dict(standing_ratio=0.7, flat_ratio=0.4), "standing_ratio \\+ flat_ratio"),
                       (dict(ramp_speed_range_mps=(0.0, 1.0)), "ramp_speed_range_mps"),
                       (dict(ranges=mdp.SmoothHeightRangesCfg(height_m=(1.0, 0.0))), "ranges.height_m"),
                       (dict(body_name="no_such_body"), "no_such_body")):
        with pytest.raises(ValueError, match=field):
            mdp.SmoothHeightCommand(mdp.SmoothHeightCommandCfg(**bad), env)
