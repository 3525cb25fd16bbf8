"""agile time_to_policy on the CPU: the training runs as its own process (the point of the tool), checkpoints are
evaluated as they appear (or after the training) and the run reports the first one that meets the criteria."""

import json
from pathlib import Path

import pytest
import torch

from commands import FLAT_GROUND_ARGS

from agile.run.recipes import RECIPES
from agile.run.time_to_policy import main, time_to_policy_options
from agile.run.time_to_policy_run import run_until_criteria


@pytest.mark.slow
def test_the_run_stops_at_the_first_checkpoint_that_meets_the_criteria(tmp_path, capsys):
    out = tmp_path / "t1"
    code = main(["--task", "Velocity-T1-v0", "--budget_s", "300", "--num_envs", "2", "--device", "cpu",
                 "--save_interval", "1", "--eval_num_envs", "2", "--eval_episode_length_s", "0.4",
                 "--criterion", "fall_rate=1.0", "--out", str(out), "agent.num_steps_per_env=4", *FLAT_GROUND_ARGS])
    result = json.loads(out.with_suffix(".json").read_text())
    assert code == 0, capsys.readouterr()
    # met at the first checkpoint evaluated (the newest when the evaluator looks: with iterations this short the
    # training may be past iteration 0 by then), and the training stopped: nothing more evaluated
    (first,) = result["evaluations"]
    assert result["criteria"] == {"fall_rate": 1.0} and result["iteration_at_criteria"] == first["iteration"]
    assert first["met"] and 0 < result["time_to_policy_s"] < 300 and result["first_iteration_s"] is not None
    # each evaluation keeps the errors by command: where a missed criterion comes from
    assert set(first["error_by_command"]) == {"lin_vel_error_mps_by_speed_mps", "ang_vel_error_radps_by_yaw_rate_radps"}
    assert "Learning iteration 0" in (tmp_path / "t1.log").read_text()  # the training's own log beside it


@pytest.mark.slow
def test_several_ranks_train_through_torchrun_on_the_cpu(tmp_path, capsys):
    """--gpus N with --device cpu: N CPU ranks (gloo) under torchrun, the path of a several-GPU run, and the
    checkpoints rank 0 wrote evaluated after the training."""
    out = tmp_path / "ranks"
    code = main(["--task", "Velocity-T1-v0", "--gpus", "2", "--device", "cpu", "--budget_s", "300",
                 "--max_iterations", "2", "--num_envs", "2", "--save_interval", "1", "--eval_num_envs", "2",
                 "--eval_episode_length_s", "0.2", "--evaluate_after_training", "--criterion", "fall_rate=1.0",
                 "--out", str(out), "agent.num_steps_per_env=2", *FLAT_GROUND_ARGS])
    result = json.loads(out.with_suffix(".json").read_text())
    assert code == 0, capsys.readouterr()
    assert result["gpus"] == 2 and result["evaluations"][0]["iteration"] == 0
    log = (tmp_path / "ranks.log").read_text()
    assert "rank 1 of 2 on cpu" in log and "all 2 ranks hold the same weights" in log


@pytest.mark.slow
def test_a_training_that_fails_is_reported_as_failed_naming_its_output(tmp_path, capsys):
    """A training process that ended with an error was reported as "criteria not met within 300 s", as if the time
    had run out."""
    broken = tmp_path / "broken.pt"
    torch.save({"iter": 3, "infos": {"wall_s": 5.0}}, broken)  # no weights: the training cannot resume it
    out = tmp_path / "failed"
    code = main(["--task", "Velocity-T1-v0", "--budget_s", "300", "--num_envs", "2", "--device", "cpu",
                 "--resume", str(broken), "--evaluate_after_training", "--criterion", "fall_rate=1.0",
                 "--out", str(out), *FLAT_GROUND_ARGS])
    result = json.loads(out.with_suffix(".json").read_text())
    assert code == 1 and result["training_exit_code"] not in (None, 0) and result["evaluations"] == []
    printed = capsys.readouterr().out
    assert f"the training failed (exit code {result['training_exit_code']})" in printed, printed
    assert f"(the training's output: {out}.log)" in printed


def test_a_run_without_an_evaluated_checkpoint_writes_no_curve(tmp_path):
    """A budget too short for a first checkpoint: the JSON says so and the curve is skipped (a plot of no metric
    was a matplotlib error after the whole run)."""
    from agile.run.time_to_policy_plots import plot

    result = {"task": "Velocity-T1-v0", "evaluations": [], "criteria": {"fall_rate": 0.05}, "first_iteration_s": None,
              "time_to_policy_s": None, "gpus": 1, "seed": None}
    assert plot([result], str(tmp_path / "curve.png"), "title") is False
    assert not (tmp_path / "curve.png").exists()


@pytest.mark.slow
def test_seeds_run_one_after_another_evaluated_after_the_training_and_summarised(tmp_path, capsys):
    """--seeds: one training per seed (its own JSON and log), then the summary over them, one curve per seed. Each
    training runs undisturbed (here to its third and last iteration, well inside the budget: on a machine compiling
    the kernels the first iteration came at 35 s); then its checkpoints are evaluated in order, and the first that
    meets the criteria (here: the first of all) gives the time to policy, when it was written. Each seed's run is
    kept (--log_root/seed<N>), and a second run resuming one's newest checkpoint is timed on from the wall time the
    checkpoint records."""
    out = tmp_path / "seeds"
    common = ["--task", "Velocity-T1-v0", "--budget_s", "300", "--num_envs", "2", "--device", "cpu",
              "--save_interval", "1", "--eval_num_envs", "2", "--eval_episode_length_s", "0.2",
              "--evaluate_after_training", "--criterion", "fall_rate=1.0", "--recipe", "fast",
              "agent.num_steps_per_env=2", *FLAT_GROUND_ARGS]
    code = main(["--seeds", "3", "4", "--max_iterations", "3", "--log_root", str(tmp_path / "runs"),
                 "--out", str(out), *common])
    assert code == 0, capsys.readouterr()
    summary = json.loads(out.with_suffix(".json").read_text())
    runs = [json.loads((tmp_path / name).read_text()) for name in summary["runs"]]
    assert summary["seeds"] == [3, 4] and [r["seed"] for r in runs] == [3, 4] and summary["met"] == 2
    assert summary["time_to_policy_s"] == [r["time_to_policy_s"] for r in runs] and not summary["missed_seeds"]
    assert summary["worst_s"] == max(summary["time_to_policy_s"])
    for seed, result in zip((3, 4), runs, strict=True):
        (first,) = result["evaluations"]
        assert first["iteration"] == 0 and first["met"] and result["evaluated"] == "after the training"
        assert result["climb"] is None  # the task's criteria: no terrain level to climb to
        assert result["time_to_policy_s"] == first["wall_s"] < 300
        # it trained on past the first checkpoint, in the training's own log beside it
        assert "Learning iteration 2" in (tmp_path / f"seeds_seed{seed}.log").read_text()
        # what it trained with is in the JSON: the recipe's overrides, then the given ones
        assert result["recipe"] == "fast" and result["overrides"][:len(RECIPES["fast"])] == list(RECIPES["fast"])
        assert result["overrides"][len(RECIPES["fast"])] == "agent.num_steps_per_env=2"
        assert Path(result["newest_checkpoint"]).is_relative_to(tmp_path / "runs" / f"seed{seed}")
    newest = runs[1]["newest_checkpoint"]
    recorded = torch.load(newest, weights_only=True)["infos"]["wall_s"]
    assert newest.endswith("model_2.pt") and 0 < recorded < 300
    # the resumed run reports its record as it goes (what <out>.json holds meanwhile): at each new checkpoint while
    # it trains, after each evaluation after it
    options, _ = time_to_policy_options(task="Velocity-T1-v0", budget_s=300, seed=4, num_envs=2, device="cpu",
                                        max_iterations=1, save_interval=1, eval_num_envs=2, eval_episode_length_s=0.2,
                                        evaluate_after_training=True, criteria={"fall_rate": 1.0}, resume=newest,
                                        recipe="fast", overrides=("agent.num_steps_per_env=2", *FLAT_GROUND_ARGS))
    reports = []
    (tmp_path / "resumed_runs").mkdir()
    resumed = run_until_criteria(options, str(tmp_path / "resumed_runs"), tmp_path / "resumed.log",
                                 report=lambda r: reports.append(json.loads(json.dumps(r))))
    assert resumed["resumed_from"] == newest and resumed["wall_s_before"] == recorded
    (row,) = resumed["evaluations"]
    assert row["iteration"] == 3 and row["wall_s"] > recorded  # the resumed run's own checkpoint, timed on
    assert resumed["status"] == "finished" and reports[-1]["status"] == "evaluating"
    assert reports[-1]["evaluations"] == [row] and {r["status"] for r in reports[:-1]} <= {"training"}
    assert all(r["evaluations"] == [] for r in reports[:-1])


def test_the_seed_summary_counts_a_miss_as_its_budget():
    from agile.run.time_to_policy import seed_summary

    runs = [{"seed": 0, "time_to_policy_s": 250.0, "budget_s": 300.0},
            {"seed": 1, "time_to_policy_s": None, "budget_s": 300.0},
            {"seed": 2, "time_to_policy_s": 190.5, "budget_s": 300.0}]
    summary = seed_summary(runs)
    assert summary["median_s"] == 250.0 and summary["worst_s"] == 300.0
    assert summary["missed_seeds"] == [1] and summary["met"] == 2 and summary["time_to_policy_s"][1] is None



def test_the_curve_title_says_whether_the_criteria_were_met():
    """A run that missed its criteria was titled "time to policy None s"."""
    from agile.run.time_to_policy_plots import outcome

    missed = {"time_to_policy_s": None, "budget_s": 420.0, "iteration_at_criteria": None}
    assert outcome(missed) == "criteria not met within 420 s"
    assert outcome({**missed, "time_to_policy_s": 287.4, "iteration_at_criteria": 650}) == \
        "time to policy 287 s (iteration 650)"
    # a training that ended by itself: its iterations done, or failed (was "not met within 420 s" either way)
    assert outcome({**missed, "training_exit_code": 0}) == \
        "criteria not met by the training's last iteration (within 420 s)"
    assert outcome({**missed, "training_exit_code": 2}) == "criteria not met: the training failed (exit code 2)"


def test_a_run_without_a_seed_is_named_by_the_tasks_seed_not_none():
    """The legend and the summary line of a run given no seed said "seed None"."""
    from agile.run.time_to_policy_plots import seed_name

    assert seed_name(None) == "the task's seed" and seed_name(0) == "seed 0" and seed_name(7) == "seed 7"


def test_a_resumed_runs_first_iteration_is_marked_after_its_checkpoints_time():
    """The curve of a resumed run (its wall times counted on from the checkpoint's) marked its first iteration at
    22.5 s, far left of its evaluations at 902-2020 s."""
    from agile.run.time_to_policy_plots import first_iteration_wall_s

    assert first_iteration_wall_s({"first_iteration_s": 22.5, "wall_s_before": 863.8}) == 863.8 + 22.5
    assert first_iteration_wall_s({"first_iteration_s": 22.5, "wall_s_before": 0.0}) == 22.5
    assert first_iteration_wall_s({"first_iteration_s": None, "wall_s_before": 863.8}) is None


def test_each_later_legs_start_is_marked_on_the_runs_time_axis():
    """--batch_schedule: the curve marks where each leg after the first started (its new batch shape)."""
    from agile.run.time_to_policy_plots import later_legs_wall_s

    legs = [{"started_s": 0.0}, {"started_s": 352.1}, {"started_s": 900.4}]
    assert later_legs_wall_s({"legs": legs, "wall_s_before": 0.0}) == [352.1, 900.4]
    assert later_legs_wall_s({"legs": legs[1:], "wall_s_before": 100.0}) == [1000.4]
    assert later_legs_wall_s({"wall_s_before": 0.0}) == []  # a record from before legs were kept
