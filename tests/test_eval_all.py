"""scripts/eval_all.py in the tiny CPU setting on every task with a shipped policy (issue 25): it loads and steps
each policy, writes a JSON per task and the report, and says that the criteria were not checked."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from commands import run_command

from agile.tasks.catalogue import evaluated_tasks

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("task", [e.task for e in evaluated_tasks()])
def test_eval_all_tiny_cpu_setting(tmp_path, task):
    """One task a test (each builds its env: spread over the workers)."""
    out = tmp_path / "eval"
    code, stdout, stderr = run_command("eval_all", "--device", "cpu", "--num_envs", "2", "--episode_length_s", "1",
                                       "--tasks", task, "--out", out)
    assert code == 0, stdout[-2000:] + stderr[-2000:]
    report = (out / "report.md").read_text()
    metrics = json.loads((out / f"{task}.json").read_text())
    assert "Criteria not checked" in report
    assert metrics["criteria_checked"] is False and metrics["device"] == "cpu" and metrics["num_envs"] == 2
    if metrics["kind"] == "multi_agent":  # a row per agent, each agent's metrics against the task's criteria
        assert metrics["agents"] and all(f"| {task} {agent} |" in report for agent in metrics["agents"])
        for agent_metrics in metrics["agents"].values():
            assert agent_metrics["episodes"] == 2 and set(metrics["criteria"]) <= set(agent_metrics)
            assert all(isinstance(v, float) and v == v for v in agent_metrics["reward_per_step"].values())
        return
    assert f"| {task} |" in report
    assert metrics["episodes"] == 2  # two envs, one 1 s episode each
    # every criterion was measured (episode metrics such as a motion's body error among episode_metrics, a bound on
    # each commanded band among the error breakdowns)
    assert set(metrics["criteria"]) <= (set(metrics) | set(metrics.get("episode_metrics", {}))
                                        | set(metrics["error_by_command"]))
    assert all(isinstance(v, float) and v == v for v in metrics["reward_per_step"].values())
    if "lin_vel_error_mps" in metrics["criteria"]:
        by_speed = metrics["error_by_command"]["lin_vel_error_mps_by_speed_mps"]
        assert by_speed and all(row["steps"] > 0 and row["error"] >= 0.0 for row in by_speed)
        by_yaw_rate = metrics["error_by_command"]["ang_vel_error_radps_by_yaw_rate_radps"]
        assert sum(row["steps"] for row in by_yaw_rate) == sum(row["steps"] for row in by_speed)  # the same steps
        mean = sum(row["error"] * row["steps"] for row in by_yaw_rate) / sum(row["steps"] for row in by_yaw_rate)
        assert mean == pytest.approx(metrics["ang_vel_error_radps"], rel=1e-4)  # the bins split the overall error
    assert ("base_height_error_m_by_height_m" in metrics["error_by_command"]) == ("base_height_error_m" in metrics)


def test_eval_all_evaluates_each_shipped_policy_file_once():
    tasks = [e.task for e in evaluated_tasks()]
    assert tasks, "no task has a shipped policy"
    # one policy file, two task IDs: evaluated once, under the file's name
    assert "Velocity-Height-G1-Teacher-v0" in tasks and "Velocity-Height-G1-v0" not in tasks


def test_eval_all_refuses_a_task_without_policy(tmp_path):
    code, _, stderr = run_command("eval_all", "--device", "cpu", "--tasks", "Debug-T1-v0", "--out", tmp_path)
    assert code == 2
    assert "Debug-T1-v0" in stderr and "Velocity-T1-v0" in stderr


def test_verdict_fails_a_checked_run_that_misses_a_criterion(monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "scripts"))
    from agile.run.eval_all import report_markdown, verdict

    result = {"task": "Velocity-T1-v0", "kind": "trainable", "device": "cuda:0", "num_envs": 512, "num_episodes": 1,
              "episode_length_s": 20.0, "fall_rate": 0.2, "lin_vel_error_mps": 0.1, "ang_vel_error_radps": 0.1,
              "mean_episode_length_s": 15.0, "reward_per_step": {"track": 1.0},
              "criteria": {"fall_rate": 0.05, "lin_vel_error_mps": 0.25}, "criteria_checked": True}
    assert verdict(result) == ("FAIL", ["fall_rate 0.2 > 0.05"])
    assert "FAIL: fall_rate 0.2 > 0.05" in report_markdown([result], plots=[])
    assert verdict({**result, "criteria_checked": False})[0] == "not checked"
    assert verdict({**result, "fall_rate": 0.01})[0] == "pass"


def test_the_report_shows_a_tasks_own_height_criterion_and_its_bands(tmp_path):
    """HeightTracking's height error is an episode metric bounded overall and in each commanded band: the report's
    height column shows it, a band over its bound fails the run, and the by-command plot draws the bands."""
    from agile.run.eval_all import plot_error_by_command, report_markdown, verdict

    bands = [{"command": [0.0, 0.4], "steps": 10, "error": 0.03, "error_se": 0.004},  # whiskers where it has one
             {"command": [0.4, 0.9], "steps": 10, "error": 0.07}]
    result = {"task": "HeightTracking-G1-v0", "kind": "trainable", "device": "cuda:0", "num_envs": 256,
              "num_episodes": 1, "episode_length_s": 15.0, "fall_rate": 0.0, "mean_episode_length_s": 15.0,
              "reward_per_step": {"track": 1.0}, "episode_metrics": {"height/height_error_m": 0.045},
              "error_by_command": {"height_error_m_by_height_m": bands},
              "criteria": {"fall_rate": 0.05, "height/height_error_m": 0.05, "height_error_m_by_height_m": 0.05},
              "criteria_checked": True}
    assert verdict(result) == ("FAIL", ["height_error_m_by_height_m [0.4, 0.9) 0.07 > 0.05"])
    assert "| 0.000 | - | - | 0.045 | 15.00 | FAIL" in report_markdown([result], plots=[])
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    assert (tmp_path / plot_error_by_command(result, str(tmp_path), plt)).is_file()
