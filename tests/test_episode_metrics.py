"""Metric terms (`MetricTerm`, the env cfg's `metrics`): the manager's per-step means and episode-end values, kept
for the ended envs only; the one merged view of command and metric-term metrics; StandUp-T1's stand-up success on
scripted states and through env.step; eval.py reports it."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import types

import pytest
import torch
from fakes import FakeEnv

import agile.tasks
from agile.rl_env import mdp
from agile.tasks.stand_up.fallen_states import FallenStateDatasetCfg
from agile.rl_env.managers import MetricsManager, MetricTerm, merge_episode_metrics
from agile.tasks.velocity.velocity_common import BASE_HEIGHT_SENSOR
from agile.utils.config import ConfigError, configclass

TASK = "StandUp-T1-v0"

# -- the manager, on a fake env -------------------------------------------------------------------------------


def step_value(env) -> torch.Tensor:
    return env.step_value_m


def end_value(env, scale: float) -> torch.Tensor:
    env.end_calls += 1
    return env.end_value_m * scale


@configclass
class Metrics:
    mean_m = MetricTerm(func=step_value)  # when="step": the default
    final_m = MetricTerm(func=end_value, params={"scale": 10.0}, when="episode_end")


def fake_env(num_envs: int = 3) -> FakeEnv:
    env = FakeEnv(num_envs)
    env.step_value_m = torch.zeros(num_envs)
    env.end_value_m = torch.zeros(num_envs)
    env.end_calls = 0
    return env


def test_step_terms_are_averaged_and_episode_end_terms_kept_for_the_ended_envs_only():
    env = fake_env()
    manager = MetricsManager(Metrics(), env)
    manager.reset(torch.ones(3, dtype=torch.bool))
    env.end_value_m.fill_(7.0)
    for values in ([1.0, 2.0, 3.0], [3.0, 4.0, 5.0]):
        env.step_value_m.copy_(torch.tensor(values))
        manager.update_metrics()
    assert env.end_calls == 0  # an episode-end term is not evaluated by the steps
    torch.testing.assert_close(manager.metrics["mean_m"], torch.tensor([2.0, 3.0, 4.0]))
    env.end_value_m.copy_(torch.tensor([1.0, 2.0, 3.0]))
    ending = torch.tensor([True, False, True])
    log = manager.finish_episodes(ending)
    last = manager.last_episode_metrics
    torch.testing.assert_close(last["mean_m"], torch.tensor([2.0, 0.0, 4.0]))  # env 1 goes on: not copied
    torch.testing.assert_close(last["final_m"], torch.tensor([10.0, 0.0, 30.0]))
    torch.testing.assert_close(manager.metrics["final_m"], torch.tensor([10.0, 0.0, 30.0]))  # env 1: not ended
    assert float(log["Metrics/mean_m"]) == pytest.approx(3.0)  # means over the ending envs only
    assert float(log["Metrics/final_m"]) == pytest.approx(20.0)
    # the ended envs start afresh; their kept values stay until they end again
    manager.reset(ending)
    torch.testing.assert_close(manager.metrics["mean_m"], torch.tensor([0.0, 3.0, 0.0]))
    assert manager.metrics["final_m"].tolist() == [0.0, 0.0, 0.0]
    env.step_value_m.copy_(torch.tensor([1.0, 1.0, float("nan")]))  # a blown-up world's step does not count
    manager.update_metrics()
    torch.testing.assert_close(manager.metrics["mean_m"], torch.tensor([1.0, 7.0 / 3.0, 0.0]))
    env.end_value_m.copy_(torch.tensor([float("inf"), 5.0, float("nan")]))
    log = manager.finish_episodes(torch.tensor([False, True, True]))
    torch.testing.assert_close(last["mean_m"], torch.tensor([2.0, 7.0 / 3.0, 0.0]))
    torch.testing.assert_close(last["final_m"], torch.tensor([10.0, 50.0, 0.0]))  # non-finite counts 0
    log = manager.finish_episodes(torch.zeros(3, dtype=torch.bool))
    assert float(log["Metrics/mean_m"]) == 0.0 and float(log["Metrics/final_m"]) == 0.0


def test_clear_errors_name_the_term_and_field():
    env = fake_env(2)
    with pytest.raises(ConfigError, match=r"metric term 'final_m': 'when' must be one of \['step', 'episode_end'\]"):
        MetricsManager(Metrics(final_m=MetricTerm(func=end_value, params={"scale": 1.0}, when="end")), env)
    with pytest.raises(ConfigError, match=r"metric term 'final_m': missing params \['scale'\]"):
        MetricsManager(Metrics(final_m=MetricTerm(func=end_value, when="episode_end")), env)
    manager = MetricsManager(Metrics(mean_m=MetricTerm(func=lambda env: torch.zeros(2, 3))), env)
    with pytest.raises(ValueError, match=r"metric term 'mean_m': .* returned shape \(2, 3\); a metric needs one value "
                                         r"per env, a tensor of shape \(2,\)"):
        manager.update_metrics()


def test_merged_view_holds_both_and_refuses_a_key_both_name():
    commands = types.SimpleNamespace(last_episode_metrics={"motion/error_m": torch.zeros(2)}, active_terms=["motion"])
    terms = types.SimpleNamespace(last_episode_metrics={"success": torch.ones(2)}, active_terms=["success"])
    env = types.SimpleNamespace(task_name="Fake-v0", command_manager=commands, metrics_manager=terms)
    merged = merge_episode_metrics(env)
    assert set(merged) == {"motion/error_m", "success"}
    assert merged["success"] is terms.last_episode_metrics["success"]  # the live tensors, written in place
    terms.last_episode_metrics["motion/error_m"] = torch.zeros(2)
    with pytest.raises(ConfigError, match=r"episode metric \['motion/error_m'\] is named both by a command term's "
                                          r"metrics \(commands: \['motion'\]\) and by a metric term"):
        merge_episode_metrics(env)


# -- StandUp-T1 ----------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def stand_up(tmp_path_factory):
    """StandUp-T1 with 3 envs on 2 terrain rows its dataset made when built (a tiny fallen-state dataset)."""
    from agile.run import task_setup

    cache_dir = tmp_path_factory.mktemp("fallen_cache")
    env_cfg, agent_cfg = agile.tasks.load_cfgs(TASK)
    env_cfg.num_envs = 3
    env_cfg.scene.terrain = dataclasses.replace(env_cfg.scene.terrain, num_rows=2, num_cols=3)
    env_cfg.events.reset_base.params["dataset"] = FallenStateDatasetCfg(cache_dir=str(cache_dir))
    with contextlib.redirect_stdout(io.StringIO()):
        env = task_setup.make_env(task=TASK, env_cfg=env_cfg, device="cpu")
    yield env, agent_cfg, cache_dir
    env.close()


def place_trunk(env, heights_m: list[float]) -> None:
    """Every env's robot upright, at rest, its trunk (the root) `heights_m` above the terrain under its height
    scanner: what the task's height rewards measure."""
    robot, scanner = env.scene["robot"], env.scene[BASE_HEIGHT_SENSOR]
    all_envs = torch.ones(env.num_envs, dtype=torch.bool)
    pose = robot.root_pose_w.clone()
    pose[:, 3:7] = torch.tensor([0.0, 0.0, 0.0, 1.0])  # the scanner's rays follow the yaw: set it first
    for _ in range(2):  # the ground under the rays depends on x, y and yaw only
        robot.write_root_state(pose, torch.zeros_like(robot.root_com_vel_w), all_envs)
        env.sim.forward(all_envs)
        env.scene.update()
        pose[:, 2] = scanner.hit_z_m.mean(dim=1) + torch.tensor(heights_m)
    torch.testing.assert_close(mdp.base_height_above_ground(env, sensor_name=BASE_HEIGHT_SENSOR),
                               torch.tensor(heights_m), atol=1e-5, rtol=0)


def test_stand_up_success_on_scripted_states(stand_up):
    env, _, _ = stand_up
    env.reset()
    terms = env.termination_manager
    assert set(env.last_episode_metrics) == {"standing_at_time_out", "not_standing_at_time_out",
                                             "base_height_at_end_m"}
    assert env.last_episode_metrics["standing_at_time_out"] is env.metrics_manager.last_episode_metrics[
        "standing_at_time_out"]
    # env 0 up at the time-out; env 1 lying at the time-out; env 2 up, but a failure term ended it in that step
    place_trunk(env, [0.65, 0.30, 0.65])
    terms.time_outs.copy_(torch.tensor([True, True, True]))
    terms.terminated.copy_(torch.tensor([False, False, True]))
    log = env.metrics_manager.finish_episodes(torch.ones(3, dtype=torch.bool))
    last = env.last_episode_metrics
    assert last["standing_at_time_out"].tolist() == [1.0, 0.0, 0.0]
    assert last["not_standing_at_time_out"].tolist() == [0.0, 1.0, 1.0]
    torch.testing.assert_close(last["base_height_at_end_m"], torch.tensor([0.65, 0.30, 0.65]), atol=1e-5, rtol=0)
    assert float(log["Metrics/standing_at_time_out"]) == pytest.approx(1.0 / 3.0)
    # the threshold is 0.55 m; only env 1 ends now (up at 0.56 m), envs 0 and 2 keep their last episode's values;
    # an episode still running when its env is reset (no time-out) is not a stand-up
    place_trunk(env, [0.54, 0.56, 0.56])
    terms.terminated.zero_()
    env.metrics_manager.finish_episodes(torch.tensor([False, True, False]))
    assert last["standing_at_time_out"].tolist() == [1.0, 1.0, 0.0]
    terms.time_outs.copy_(torch.tensor([True, True, False]))
    env.metrics_manager.finish_episodes(torch.ones(3, dtype=torch.bool))
    assert last["standing_at_time_out"].tolist() == [0.0, 1.0, 0.0]
    env.reset()


def test_stand_up_success_through_the_env_step(stand_up):
    """A real step ending every episode by time-out: env 0 starts standing, the others from fallen states."""
    env, _, _ = stand_up
    env.reset()
    reset_base = env.event_manager.get_term("reset_base")
    env.scene.reset_to_default(torch.tensor([True, False, False]))
    reset_base(env, torch.tensor([True, False, False]), standing_ratio=1.0)
    reset_base(env, torch.tensor([False, True, True]), standing_ratio=0.0)
    env.sim.forward(torch.ones(3, dtype=torch.bool))
    env.scene.update()
    env.episode_length_buf.fill_(env.max_episode_length - 1)  # the next step is the last
    _, _, terminated, truncated, extras = env.step(torch.zeros(3, env.action_manager.total_action_dim))
    # every episode times out; the lying ones also end by no_height_progress (their clocks say 15 s without rising)
    assert truncated.all() and terminated.tolist() == [False, True, True]
    last = env.last_episode_metrics
    assert last["standing_at_time_out"].tolist() == [1.0, 0.0, 0.0]
    assert last["base_height_at_end_m"][0] > 0.55 and (last["base_height_at_end_m"][1:] < 0.4).all()
    assert float(extras["log"]["Metrics/standing_at_time_out"]) == pytest.approx(1.0 / 3.0)
    assert float(extras["log"]["Metrics/not_standing_at_time_out"]) == pytest.approx(2.0 / 3.0)
    env.reset()


def test_stand_up_registration_holds_the_issue_criterion():
    from agile.tasks.catalogue import task_entry

    entry = task_entry(TASK)
    assert entry.criteria["not_standing_at_time_out"] == 0.10 and entry.criteria["fall_rate"] == 0.10
    assert entry.eval_settings["episode_length_s"] == 10.0
    assert "env.scene.max_init_terrain_level=3" in entry.eval_settings["overrides"]


def test_eval_reports_the_stand_up_success(stand_up, tmp_path):
    """eval.py on StandUp-T1 (2 envs, 0.2 s episodes, every one from a fallen state, the lift removed): no robot
    stands at the time-out."""
    from agile.run import eval as eval_script
    from rsl_rl.runners import OnPolicyRunner

    from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict

    env, agent_cfg, cache_dir = stand_up
    checkpoint = tmp_path / "model.pt"
    OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=None, device="cpu").save(str(checkpoint))
    out = tmp_path / "eval.json"
    with contextlib.redirect_stdout(io.StringIO()):
        eval_script.main(["--task", TASK, "--checkpoint", str(checkpoint), "--device", "cpu", "--num_envs", "2",
                          "--episode_length_s", "0.2", "--out", str(out), "env.scene.terrain.num_rows=2",
                          f"env.events.reset_base.params.dataset.cache_dir={cache_dir}",
                          "env.events.reset_base.params.standing_ratio=0.0"])
    metrics = json.loads(out.read_text())
    found = metrics["episode_metrics"]
    assert set(found) == {"standing_at_time_out", "not_standing_at_time_out", "base_height_at_end_m"}
    assert metrics["episodes"] == 2 and metrics["falls"] == 0
    assert found["standing_at_time_out"] == 0.0 and found["not_standing_at_time_out"] == 1.0
    assert 0.0 < found["base_height_at_end_m"] < 0.4  # lying: the trunk far below its standing 0.65 m
