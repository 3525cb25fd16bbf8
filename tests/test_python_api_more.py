"""The rest of the runtime as a library, called from Python without the command line: time to policy (its options and
criteria), picking a checkpoint, a learning curve, the plain-MuJoCo replay, the commands' options dispatched by kind,
and the stand-up family's startup dataset; refused input raised as AgileError (not SystemExit)."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil

import pytest

from commands import FLAT_GROUND_ARGS

from agile.errors import AgileError

TASK = "Velocity-T1-v0"
MULTI_AGENT_TASK = "MultiRate-G1-T1-Velocity-v0"


@pytest.mark.parametrize("changes, message", [
    ({"budget_s": 0}, "budget_s must be positive, got 0"),
    ({"gpus": 0}, "gpus must be at least 1, got 0"),
    ({"save_interval": 0}, "save_interval must be at least 1, got 0"),
    ({"eval_num_envs": 0}, "eval_num_envs must be at least 1, got 0"),
    ({"seed": 1, "seeds": [2, 3]}, "seed and seeds: give one"),
    ({"seeds": []}, "seeds must name at least one seed"),
    ({"recipe": "slow"}, "recipe must be one of fast (or None), got 'slow'"),
    ({"criteria": {"fall_rate": "low"}}, "criteria: {metric: maximum}, a number each; fall_rate is 'low'"),
    ({"task": "Velocity-Nope-v0"}, "unknown task 'Velocity-Nope-v0'. Registered tasks: "),
    ({"batch_schedule": [(1000, 1024, 96), (900, 512, 192)]}, "batch_schedule: the iterations must rise"),
    ({"batch_schedule": [(1000, 1024)]}, "batch_schedule: each entry is (after_iteration >= 0, num_envs >= 1"),
    ({"overrides": ["agent.nope=1"]}, "'agent' has no field 'nope'. Fields: "),  # was the training's error, unseen
])
def test_time_to_policy_refuses_bad_options_naming_the_field_before_anything_runs(tmp_path, changes, message):
    from agile.run.time_to_policy import time_to_policy

    options = {"task": TASK, "budget_s": 5.0, "out": str(tmp_path / "run"), "device": "cpu", **changes}
    with pytest.raises(AgileError, match=re.escape(message)):
        time_to_policy(**options)
    assert not list(tmp_path.iterdir())  # nothing written, no training started


def test_time_to_policy_resolves_its_criteria_recipe_and_training_command():
    from agile.run.recipes import RECIPES
    from agile.run.time_to_policy import parse_criteria, time_to_policy_options
    from agile.run.time_to_policy_run import training_command
    from agile.run.time_to_policy_judge import criteria_of
    from agile.tasks.catalogue import task_entry

    options, seeds = time_to_policy_options(task=TASK, budget_s=5.0, device="cpu", recipe="fast", seeds=[3, 4],
                                            overrides=["agent.num_steps_per_env=4"])
    assert seeds == [3, 4] and options.seed is None and options.device == "cpu"
    assert options.overrides == (*RECIPES["fast"], "agent.num_steps_per_env=4")  # the recipe's first
    entry = task_entry(TASK)
    assert criteria_of(TASK, options.target, options.criteria) == (dict(entry.criteria), dict(entry.minima))
    assert entry.criteria  # the task's
    assert criteria_of(TASK, "criteria", {"fall_rate": 0.5}) == ({"fall_rate": 0.5}, {})  # given maxima, no minima
    assert parse_criteria(["fall_rate=0.5", "lin_vel_error_mps=0.2"]) == {"fall_rate": 0.5, "lin_vel_error_mps": 0.2}
    with pytest.raises(AgileError, match="--criterion takes NAME=MAXIMUM, e.g. fall_rate=0.05; got 'fall_rate'"):
        parse_criteria(["fall_rate"])

    command = training_command(options, "/tmp/runs")
    assert command[1:3] == ["-m", "agile.run.train"] and command[-2:] == ["--device", "cpu"]
    assert "agent.save_interval=50" in command and command.index(RECIPES["fast"][0]) < command.index(
        "agent.num_steps_per_env=4")
    ranks, _ = time_to_policy_options(task=TASK, budget_s=5.0, device="cpu", gpus=2, seed=7)
    command = training_command(ranks, "/tmp/runs")
    assert "--nproc_per_node=2" in command and command[-3:] == ["--distributed", "--device", "cpu"]
    assert command[command.index("--seed") + 1] == "7"
    resumed = dataclasses.replace(options, resume="run/model_50.pt")
    assert training_command(resumed, "/tmp/runs")[-4:-2] == ["--checkpoint", "run/model_50.pt"]


def test_the_command_line_overrides_without_the_recipes():
    from agile.run import arguments
    from agile.run.recipes import RECIPES

    parser = arguments.new_parser("test")
    parser.add_argument("overrides", nargs="*")
    arguments.add_recipe_arg(parser)
    args = arguments.parse(parser, ["--recipe", "fast", "agent.x=1"])
    assert args.overrides == [*RECIPES["fast"], "agent.x=1"] and arguments.given_overrides(args) == ["agent.x=1"]
    args = arguments.parse(parser, ["agent.x=1"])
    assert arguments.given_overrides(args) == ["agent.x=1"]


def test_pick_checkpoint_from_python_ranks_a_runs_checkpoints(tmp_path):
    from agile.run.pick_checkpoint import pick_checkpoint
    from agile.tasks import pretrained_policy

    run = tmp_path / "run"
    run.mkdir()
    shutil.copy(pretrained_policy(TASK), run / "model_100.pt")
    picked = pick_checkpoint(task=TASK, run_dir=str(run), every=100, device="cpu", num_envs=2, episode_length_s=0.4,
                             overrides=list(FLAT_GROUND_ARGS))
    assert picked["best"] == 100 and [row["iteration"] for row in picked["rows"]] == [100]
    assert picked["criteria_judged"] is False and picked["num_envs"] == 2 and picked["rows"][0]["met"] is None
    with pytest.raises(AgileError, match="--every must be >= 1, got 0"):
        pick_checkpoint(task=TASK, run_dir=str(run), every=0)
    with pytest.raises(AgileError, match="no such folder"):
        pick_checkpoint(task=TASK, run_dir=str(tmp_path / "nope"))
    with pytest.raises(AgileError, match="Debug-T1-v0 has no evaluation criteria"):
        pick_checkpoint(task="Debug-T1-v0", run_dir=str(run))


def test_plot_learning_curve_from_python_returns_the_png(tmp_path):
    pytest.importorskip("matplotlib")
    from torch.utils.tensorboard import SummaryWriter

    from agile.run.plot_learning_curve import plot_learning_curve

    for name, values in (("run_a", [1.0, 2.0, 3.0]), ("run_b", [4.0, 5.0])):
        writer = SummaryWriter(log_dir=str(tmp_path / name))
        for iteration, value in enumerate(values):
            writer.add_scalar("Train/mean_reward", value, iteration)
        writer.close()
    path = plot_learning_curve(runs=[str(tmp_path / "run_a")], labelled=[f"b={tmp_path / 'run_b'}"])
    assert path == tmp_path / "run_a" / "learning_curve.png" and path.stat().st_size > 0
    out = plot_learning_curve(runs=[str(tmp_path / "run_a")], out=str(tmp_path / "curve.png"),
                              tags=["Train/mean_reward"], title="reward")
    assert out == tmp_path / "curve.png" and out.is_file()
    with pytest.raises(AgileError, match="give a run folder"):
        plot_learning_curve()
    with pytest.raises(AgileError, match="--run takes LABEL=path"):
        plot_learning_curve(labelled=["no_paths"])
    with pytest.raises(AgileError, match="no run logged \\['Loss/behavior'\\]"):
        plot_learning_curve(runs=[str(tmp_path / "run_a")], tags=["Loss/behavior"])


def test_sim2mujoco_from_python_returns_the_metrics(tmp_path):
    pytest.importorskip("mujoco")
    from agile.run.export import export_checkpoint
    from agile.run.sim2mujoco import sim2mujoco

    with pytest.raises(AgileError, match="give either --bundle, or --io and --policy"):
        sim2mujoco(io=str(tmp_path / "io_descriptor.yaml"))
    files = export_checkpoint(task=TASK, out_dir=str(tmp_path / "exported"), device="cpu",
                              overrides=list(FLAT_GROUND_ARGS))
    metrics = sim2mujoco(io=files["io_descriptor"], policy=files["jit"], episodes=1, duration_s=0.2,
                         command=[0.5, 0.0, 0.0])
    assert metrics["episodes"] == 1 and 0.0 <= metrics["fall_rate"] <= 1.0 and metrics["policy"] == files["jit"]
    assert metrics["command"] == [0.5, 0.0, 0.0] and metrics["duration_s"] == 0.2 and "lin_vel_error_mps" in metrics
    with pytest.raises(AgileError):  # a command of the wrong length for the policy's velocity command
        sim2mujoco(io=files["io_descriptor"], policy=files["jit"], command=[0.5, 0.0])


def test_play_and_a_sweep_run_from_their_options(tmp_path):
    from agile.run.eval import EvalOptions, check_eval_options
    from agile.run.play import PlayOptions, check_play_options
    from agile.run.task_kinds import run_command

    played = run_command("play", TASK, PlayOptions(task=TASK, device="cpu", num_envs=1, num_steps=3, sinusoidal=True,
                                                   overrides=FLAT_GROUND_ARGS))
    assert played["steps"] == 3 and played["env_steps_per_s"] > 0 and played["falls"] <= played["episodes"]
    with pytest.raises(AgileError, match="viewer must be one of none, viser"):
        run_command("play", TASK, PlayOptions(task=TASK, viewer="vr"))
    with pytest.raises(AgileError, match="--video_reference draws into the --video mp4"):
        check_play_options(PlayOptions(task=TASK, video_reference=True))

    out = tmp_path / "sweep.json"
    options = EvalOptions(task=TASK, device="cpu", num_envs=2, episode_length_s=0.2, sweep_lin_vel_x=(0.0, 0.5),
                          overrides=FLAT_GROUND_ARGS, out=str(out))
    check_eval_options(options)
    result = run_command("eval", TASK, options)
    assert [cell["command"] for cell in result["cells"]] == [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]]
    assert json.loads(out.read_text())["cells"] == result["cells"]
    with pytest.raises(AgileError, match="--sweep_command holds its own commands"):
        check_eval_options(EvalOptions(task=TASK, sweep_command=(0.5,), command=(0.5, 0.0, 0.0)))
    with pytest.raises(AgileError, match="--usd and --video record an evaluation's rollout, not a sweep's"):
        run_command("eval", TASK, EvalOptions(task=TASK, sweep_lin_vel_x=(0.0,), video=str(tmp_path / "v.mp4")))


def test_a_multi_agent_task_refuses_single_agent_options_before_anything_is_built(tmp_path):
    from agile.run.eval import EvalOptions
    from agile.run.export import ExportOptions
    from agile.run.play import PlayOptions
    from agile.run.task_kinds import run_command

    with pytest.raises(AgileError, match="--format leapp: a multi-agent task exports each group's policy as"):
        run_command("export", MULTI_AGENT_TASK, ExportOptions(task=MULTI_AGENT_TASK, out_dir=str(tmp_path),
                                                              format="leapp"))
    with pytest.raises(AgileError, match="--command, the sweeps and --usd are single-agent options"):
        run_command("eval", MULTI_AGENT_TASK, EvalOptions(task=MULTI_AGENT_TASK, command=(0.5, 0.0, 0.0)))
    with pytest.raises(AgileError, match="--viewer, --usd and --sinusoidal are single-agent options"):
        run_command("play", MULTI_AGENT_TASK, PlayOptions(task=MULTI_AGENT_TASK, sinusoidal=True))
    with pytest.raises(AgileError, match="--checkpoint of a multi-agent task is a training run folder"):
        run_command("eval", MULTI_AGENT_TASK, EvalOptions(task=MULTI_AGENT_TASK, checkpoint=str(tmp_path / "nope")))


def test_the_stand_up_startup_dataset_is_collected_anew_through_the_task_spec():
    import agile.tasks
    from agile.rl_env.managers import EventTerm
    from agile.run.task_setup import load_task
    from agile.tasks.stand_up.fallen_states import reset_from_fallen_dataset
    from agile.utils.config import load_entry_point

    env_cfg, _, _ = load_task(task="StandUp-T1-v0", device="cpu")
    collect_anew = load_entry_point(agile.tasks.task_spec("StandUp-T1-v0").startup_dataset)
    assert collect_anew.__module__ == "agile.tasks.stand_up.fallen_states.startup"
    collect_anew(env_cfg)
    resets = [term for term in vars(env_cfg.events).values()
              if isinstance(term, EventTerm) and term.func is reset_from_fallen_dataset]
    assert resets and all(term.params["dataset"].use_cache is False for term in resets)


def test_a_multi_agent_benchmark_from_python_returns_a_row_per_env_count(tmp_path):
    from agile.run.benchmark import BenchmarkOptions
    from agile.run.task_kinds import run_command

    out = tmp_path / "benchmark.json"
    rows = run_command("benchmark", MULTI_AGENT_TASK, BenchmarkOptions(task=MULTI_AGENT_TASK, num_envs=(1,),
                                                                       device="cpu", steps=2, out=str(out)))
    (row,) = rows
    assert row["num_envs"] == 1 and set(row["single_agent"]) == {"g1", "t1"} and row["seconds_per_simulated_s"] > 0
    assert row["ratio_to_sum"] == pytest.approx(row["seconds_per_simulated_s"] / row["sum_of_single_agent_s"])
    assert json.loads(out.read_text())["results"] == json.loads(json.dumps(rows))


def test_a_trainings_wall_time_counts_from_the_train_call(tmp_path, monkeypatch):
    """What `train` does before the env build is in the checkpoints' wall time: on a GPU host its imports (torch with
    CUDA, Warp, Newton) took 13-19 s that a resumed `agile time_to_policy` run did not count."""
    import os
    import time

    import torch

    import agile.run.train as train_module

    ranks = train_module.distributed_rank

    def slow_rank(options):
        time.sleep(2.0)  # as the imports take on a GPU host, before the env is built
        return ranks(options)

    monkeypatch.setattr(train_module, "distributed_rank", slow_rank)
    called = time.time()
    run = train_module.train(task=TASK, num_envs=2, device="cpu", max_iterations=1, log_root=str(tmp_path),
                             progress="log", overrides=["agent.num_steps_per_env=2", *FLAT_GROUND_ARGS])
    wall_s = torch.load(run.checkpoint, weights_only=True)["infos"]["wall_s"]
    written_s = os.path.getmtime(run.checkpoint) - called
    assert wall_s > 2.0 and written_s - wall_s < 0.5, (wall_s, written_s)
