"""The commands as a user runs them (CPU), in this process (`agile.run.<command>.main`). What the libraries underneath
print, in fresh interpreters: tests/test_quiet_output.py."""

import json
import os
import re
import time
from pathlib import Path

import pytest
import yaml
from commands import FLAT_GROUND_ARGS, SMALL_TERRAIN_ARGS, run_command

ROOT = Path(__file__).resolve().parents[1]


def command_of(script: str) -> str:
    """scripts/train.py -> train (the thin wrappers' commands)."""
    return Path(script).stem


def run(script, *args, timeout=600):
    """(exit code, stdout and stderr) of `python scripts/<command>.py ARGS`, run in this process from the checkout."""
    code, out, err = run_command(command_of(script), *args, cwd=ROOT)
    return code, out + err


def run_split(script, *args, timeout=600):
    """(exit code, stdout, stderr)."""
    return run_command(command_of(script), *args, cwd=ROOT)


@pytest.fixture(scope="module")
def trained_run(tmp_path_factory):
    """A 2-iteration T1 training run on CPU, on its terrain (a resume restores the terrain levels): (its log folder,
    the train command line)."""
    log_root = tmp_path_factory.mktemp("logs")
    args = ["scripts/train.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--max_iterations", "2",
            "--device", "cpu", "--log_root", str(log_root), "agent.num_steps_per_env=4"]
    code, out = run(*args)
    assert code == 0, out
    return next((log_root / "velocity_t1").iterdir()), args


def option_help(help_text: str) -> dict[str, str]:
    """{option: its help text} from argparse's --help output."""
    entries, name = {}, None
    for line in help_text.splitlines():
        if line.startswith("  -"):
            invocation, _, text = line.strip().partition("  ")
            name = invocation.split(",")[0].split()[0]
            entries[name] = text.strip()
        elif name is not None and line.startswith("    "):
            entries[name] += " " + line.strip()
        else:
            name = None
    return {k: v for k, v in entries.items() if k != "-h"}


@pytest.mark.parametrize("command", ["train", "play", "eval", "eval_all", "benchmark", "export", "sim2mujoco"])
def test_help_of_every_command(command, capsys):
    import importlib

    with pytest.raises(SystemExit) as exit_info:
        importlib.import_module(f"agile.run.{command}").main(["--help"])
    out = capsys.readouterr().out
    assert exit_info.value.code == 0 and out.startswith("usage:"), out
    assert "(default: " in out, f"{command} --help shows no defaults"
    helps = option_help(out)
    assert not [name for name, text in helps.items() if "(default: None)" in text or text.count("(default") > 1], out
    assert not [name for name, text in helps.items() if not re.sub(r"\(default: [^)]*\)", "", text).strip()
                ], f"{command}: options without help"
    if command in ("train", "play", "eval", "export"):  # the override syntax, with an example of each kind
        assert "weight=2.0" in out and "activation=relu" in out and "hidden_dims=[128, 128]" in out \
            and "terrain=null" in out, out


def test_the_examples_in_every_commands_help_keep_their_line_breaks():
    """A backslash ending an example line of a command's docstring joined the two lines in --help ("...training
    --log_root" run together with the spaces of the indent); the docstrings write it as the shell does, "\\"."""
    import importlib

    from agile.cli import FORWARDED

    joined = {name: re.findall(r"\S {4,}--\w+", importlib.import_module(f"agile.run.{name}").__doc__ or "")
              for name in FORWARDED}
    assert not {name: found for name, found in joined.items() if found}


@pytest.mark.parametrize("argv", [
    ("scripts/play.py", "--checkpoint", "missing.pt"),
    ("scripts/eval.py", "--checkpoint", "missing.pt"),
    ("scripts/export.py", "--checkpoint", "missing.pt", "--out", "exported"),
    ("scripts/train.py", "--checkpoint", "missing.pt"),
    ("scripts/play.py", "--num_envs", "0"),
    ("scripts/train.py", "--max_iterations", "0"),
    ("scripts/eval.py", "--num_episodes", "-1"),
    ("scripts/eval.py", "--sweep_command", "0.5", "--command", "0.5", "0", "0"),
])
def test_a_bad_path_or_count_is_one_line_and_exit_code_2_before_the_env_is_built(argv):
    code, out, err = run_split(*argv, "--task", "Velocity-T1-v0", "--device", "cpu", timeout=120)
    assert code == 2, (out, err)
    assert len(err.strip().splitlines()) == 1 and err.startswith("error: "), err
    assert "building" not in out, out  # refused before the env build


def test_train_writes_checkpoint_logs_and_configs_then_resumes(trained_run):
    run_dir, args = trained_run
    assert (run_dir / "model_1.pt").is_file()
    assert (run_dir / "params" / "env.yaml").is_file() and (run_dir / "params" / "agent.yaml").is_file()
    assert list(run_dir.glob("events.out.tfevents.*"))
    import re

    import torch

    checkpoint = torch.load(run_dir / "model_1.pt", weights_only=True)
    env_state = checkpoint["infos"]["env_state"]
    assert int(env_state["common_step_counter"]) == 2 * 4  # 2 iterations of 4 steps: what the weight ramps read
    assert env_state["terrain_levels"].shape == (2,)
    # the training's wall time since its start, the env build included; a resume counts on from the checkpoint's:
    # set far beyond what the runs take, the resumed run's checkpoints hold it plus the resumed run's own time
    assert 0 < checkpoint["infos"]["wall_s"] < 600
    checkpoint["infos"]["wall_s"] = 1e6
    torch.save(checkpoint, run_dir / "model_1.pt")
    started = time.time()
    code, out = run(*args[:-1], "--resume", "agent.num_steps_per_env=4")
    resumed_run_s = time.time() - started
    assert code == 0 and "resuming from" in out, out
    resumed = int(re.search(r"resuming from \S*model_(\d+)\.pt", out).group(1))
    assert f"continuing at iteration {resumed + 1}" in out and f"Learning iteration {resumed + 1}/" in out, out
    assert f"Learning iteration {resumed}/" not in out  # the checkpoint's iteration is not run again
    # --max_iterations 2 after the checkpoint's: its last checkpoint is 2 later, and the env-step counter (what
    # the reward-weight ramps read) went on from the checkpoint's instead of starting over at 0
    resumed_run = next(p for p in run_dir.parent.iterdir() if (p / f"model_{resumed + 2}.pt").is_file())
    last = torch.load(resumed_run / f"model_{resumed + 2}.pt", weights_only=True)
    assert last["iter"] == resumed + 2
    assert int(last["infos"]["env_state"]["common_step_counter"]) == (resumed + 1 + 2) * 4
    assert resumed == 1 and 1e6 < last["infos"]["wall_s"] <= 1e6 + resumed_run_s
    # counted from the train call, before the imports it needs: of the time from the command's start to that
    # checkpoint only the interpreter's start is left out, not the 10-18 s of torch's, Warp's and Newton's imports
    uncounted_s = (os.path.getmtime(resumed_run / f"model_{resumed + 2}.pt") - started) - (last["infos"]["wall_s"] - 1e6)
    assert uncounted_s < 3.0, f"{uncounted_s:.1f} s of the run before its first counted second"


def test_resuming_into_another_env_is_one_line_naming_the_checkpoint(trained_run):
    """A checkpoint trained on a terrain resumed on flat ground (no terrain curriculum to take its state)."""
    run_dir, args = trained_run
    checkpoint = str(run_dir / "model_1.pt")
    code, out, err = run_split(*args[:-1], "--resume", "--checkpoint", checkpoint, "agent.num_steps_per_env=4",
                               *FLAT_GROUND_ARGS)
    assert code == 2, (out, err)
    assert len(err.strip().splitlines()) == 1 and err.startswith(f"error: --checkpoint {checkpoint}: "), err
    assert "terrain_levels" in err, err


def test_train_with_injected_nan_actions_logs_the_envs_it_ended(tmp_path):
    """The fault injection of the GPU reliability run, on CPU: NaN actions in half of the envs at the start of
    every iteration after the first; the log of that iteration counts them, the first one's does not."""
    import re

    code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--num_envs", "4", "--max_iterations", "2",
                    "--device", "cpu", "--log_root", str(tmp_path), "--inject_nan_actions", "0.5", "1",
                    "agent.num_steps_per_env=4", *FLAT_GROUND_ARGS)
    assert code == 0, out
    assert "fault injection 1: NaN actions in 2 envs" in out and "fault injection 2" not in out, out
    iterations = out.split("Learning iteration ")[1:]
    counts = [float(re.search(r"Episode_Termination/invalid_action:\s+([0-9.]+)", text).group(1))
              for text in iterations]
    assert len(counts) == 2 and counts[0] == 0.0 and counts[1] > 0.0, out
    code, out, err = run_split("scripts/train.py", "--task", "Velocity-T1-v0", "--device", "cpu",
                               "--inject_nan_actions", "1.5", "1")
    assert code == 2 and "SHARE within (0, 1]" in err, err


def test_train_init_policy_starts_from_the_shipped_actor(tmp_path):
    import torch

    shipped = ROOT / "agile" / "data" / "policy" / "Velocity-T1-v0.pt"
    code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--max_iterations", "1",
                    "--device", "cpu", "--log_root", str(tmp_path), "--init_policy", str(shipped),
                    "agent.num_steps_per_env=4", *FLAT_GROUND_ARGS)
    assert code == 0 and "actor initialised from" in out, out
    checkpoint = next((tmp_path / "velocity_t1").iterdir()) / "model_0.pt"
    trained = torch.load(checkpoint, weights_only=True)
    assert trained["iter"] == 0
    shipped_std = torch.load(shipped, weights_only=True)["actor_state_dict"]["distribution.std_param"]
    assert (shipped_std < 0.5).all()  # a fresh actor starts at 1.0: the weights did come from the file
    assert torch.allclose(trained["actor_state_dict"]["distribution.std_param"], shipped_std, atol=0.02)
    assert (checkpoint.parent / "init_policy.pt").is_file()  # where the run started stays with it
    code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--device", "cpu", "--init_policy", "nope.pt")
    assert code != 0 and "--init_policy file not found" in out


def test_train_init_action_std_resets_the_loaded_actors_noise(tmp_path):
    import torch

    shipped = ROOT / "agile" / "data" / "policy" / "Velocity-T1-v0.pt"
    code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--max_iterations", "1",
                    "--device", "cpu", "--log_root", str(tmp_path), "--init_policy", str(shipped),
                    "--init_action_std", "0.4", "agent.num_steps_per_env=4", *FLAT_GROUND_ARGS)
    assert code == 0 and "action noise reset to std 0.4" in out, out
    run_dir = next((tmp_path / "velocity_t1").iterdir())
    trained = torch.load(run_dir / "model_0.pt", weights_only=True)["actor_state_dict"]
    shipped_actor = torch.load(shipped, weights_only=True)["actor_state_dict"]
    assert torch.allclose(trained["distribution.std_param"], torch.full((12,), 0.4), atol=0.02)
    # the rest of the actor is the shipped one (one update moves it a little)
    assert torch.allclose(trained["mlp.0.weight"], shipped_actor["mlp.0.weight"], atol=0.05)
    for bad in (["--init_action_std", "0.3"], ["--init_policy", str(shipped), "--init_action_std", "-1"]):
        code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--device", "cpu", *bad)
        assert code != 0 and "--init_action_std needs --init_policy and a positive value" in out, out


def test_train_rejects_bad_input(tmp_path):
    code, out = run("scripts/train.py", "--task", "Nope-v0", "--device", "cpu")
    assert code != 0 and "Registered tasks" in out
    code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--device", "cpu", "env.rewards.nope.weight=1")
    assert code != 0 and "has no field 'nope'" in out


def test_play_runs_sinusoidal_actions():
    code, out = run("scripts/play.py", "--task", "Velocity-G1-History-v0", "--num_envs", "2", "--num_steps", "10",
                    "--device", "cpu", *FLAT_GROUND_ARGS)
    assert code == 0 and "10 steps" in out, out


def test_a_shipped_policy_runs_in_the_env_it_was_trained_in(tmp_path, monkeypatch, capsys):
    """A shipped policy with conditions in conditions.yaml (none has them now) gets them before the user's
    overrides, which still win; play, eval and export all take the shipped policy through task_setup.shipped_policy."""
    import agile.tasks
    from agile.run import task_setup

    conditions = tmp_path / "conditions.yaml"
    conditions.write_text("Velocity-Height-G1-Teacher-v0:\n  trained_on: flat ground\n"
                          "  env_overrides: [env.scene.terrain=null, env.curriculum.terrain_levels=null]\n")
    monkeypatch.setattr(agile.tasks, "PRETRAINED_CONDITIONS", conditions)
    given = ["env.num_envs=3"]
    path, overrides = task_setup.shipped_policy(task="Velocity-Height-G1-v0", overrides=given)
    assert path.endswith("Velocity-Height-G1-Teacher-v0.pt") and given == ["env.num_envs=3"]  # the caller's untouched
    assert overrides == ["env.scene.terrain=null", "env.curriculum.terrain_levels=null", "env.num_envs=3"]
    assert "shipped policy: trained on flat ground" in capsys.readouterr().out
    path, overrides = task_setup.shipped_policy(task="Velocity-G1-History-v0")
    assert path.endswith("Velocity-G1-History-v0.pt") and overrides == []


def test_eval_of_a_shipped_policy_trained_on_the_registered_task(tmp_path):
    out_file = tmp_path / "eval.json"
    code, out = run("scripts/eval.py", "--task", "Velocity-Height-G1-Teacher-v0", "--num_envs", "2", "--device", "cpu",
                    "--episode_length_s", "0.2", "--out", str(out_file))
    assert code == 0 and "shipped policy: trained on" not in out, out
    assert json.loads(out_file.read_text())["checkpoint"].endswith("Velocity-Height-G1-Teacher-v0.pt")
    # a summary on the screen, every metric in the file
    assert "Velocity-Height-G1-Teacher-v0: 2 episodes of 0.2 s (2 envs on cpu)" in out and "  fall_rate: " in out
    assert f"[agile] metrics: {out_file}" in out and '"reward_per_step"' not in out, out


def test_benchmark_runs_on_cpu(tmp_path):
    out_file = tmp_path / "bench.json"
    code, out = run("scripts/benchmark.py", "--task", "Velocity-T1-v0", "--device", "cpu", "--num_envs", "2",
                    "--steps", "5", "--train_iterations", "3", "--out", str(out_file), *SMALL_TERRAIN_ARGS)
    assert code == 0 and out_file.is_file(), out
    row = json.loads(out_file.read_text())["results"][0]
    # T1 on a terrain touches the ground with both feet: rows and contacts were used, none past the cap
    assert 0 < row["peak_constraint_rows_per_world"] <= row["njmax"] and row["constraint_row_overflows"] == 0
    assert 0 < row["peak_contacts_mean_per_world"] <= row["contact_capacity_per_world"]
    # the training's iteration from log to log (the run's start and end left out), and the run's mean with them
    assert 0 < row["iteration_median_s"] <= row["iteration_slowest_s"] and row["iteration_with_run_ends_s"] > 0
    assert row["iteration_median_s"] <= row["iteration_s"] * 1.5 and row["iteration_slowest_of_run"] in (2, 3)
    assert row["ppo_update_captures_in_run"] == 0 and row["full_gc_collections_in_run"] >= 0  # no graph on a CPU
    assert row["train"] == pytest.approx(2 * 24 / row["iteration_s"])  # 2 envs x 24 steps an iteration


def test_play_and_eval_run_a_checkpoint(trained_run, tmp_path):
    run_dir, _ = trained_run
    checkpoint = str(sorted(run_dir.glob("model_*.pt"))[-1])
    code, out = run("scripts/play.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--num_steps", "5",
                    "--device", "cpu", "--checkpoint", checkpoint, *FLAT_GROUND_ARGS)
    assert code == 0 and "5 steps" in out, out
    metrics_file = tmp_path / "eval.json"
    # flat ground for the USD stage: a rough terrain is a 6-million-vertex mesh in it (a minute of writing on a CPU)
    code, out = run("scripts/eval.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--device", "cpu",
                    "--checkpoint", checkpoint, "--episode_length_s", "0.5", "--out", str(metrics_file),
                    "--usd", str(tmp_path / "eval.usda"), *FLAT_GROUND_ARGS)
    assert code == 0 and (tmp_path / "eval.usda").is_file(), out
    metrics = json.loads(metrics_file.read_text())
    assert metrics["episodes"] >= 2 and 0.0 <= metrics["fall_rate"] <= 1.0
    assert metrics["lin_vel_error_mps"] >= 0.0 and "track_lin_vel_xy_exp" in metrics["reward_per_step"]


def test_actor_only_policy_file_loads_like_a_checkpoint(trained_run, tmp_path):
    """The format agile ships policies in (agile/data/policy/<task>.pt): the actor of a checkpoint only."""
    import torch

    run_dir, _ = trained_run
    saved = torch.load(sorted(run_dir.glob("model_*.pt"))[-1], weights_only=True)
    actor_only = tmp_path / "actor.pt"
    torch.save({"actor_state_dict": saved["actor_state_dict"], "iter": saved["iter"], "infos": None}, actor_only)
    code, out = run("scripts/eval.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--device", "cpu",
                    "--checkpoint", str(actor_only), "--episode_length_s", "0.2", "--command", "0.3", "0", "0",
                    *FLAT_GROUND_ARGS)
    assert code == 0 and "Velocity-T1-v0: 2 episodes of 0.2 s" in out and "  fall_rate: " in out, out  # the summary


def test_export_and_sim2mujoco_scripts(trained_run, tmp_path):
    run_dir, _ = trained_run
    assert (run_dir / "exported" / "policy.onnx").is_file()  # train.py exports at the end
    checkpoint = str(sorted(run_dir.glob("model_*.pt"))[-1])
    out = tmp_path / "exported"
    code, text = run("scripts/export.py", "--task", "Velocity-T1-v0", "--device", "cpu", "--checkpoint", checkpoint,
                     "--out", str(out), *FLAT_GROUND_ARGS)
    assert code == 0 and (out / "io_descriptor.yaml").is_file(), text
    metrics_file = tmp_path / "s2m.json"
    code, text = run("scripts/sim2mujoco.py", "--io", str(out / "io_descriptor.yaml"), "--policy",
                     str(out / "policy.pt"), "--episodes", "1", "--duration_s", "1.0", "--out", str(metrics_file))
    assert code == 0, text
    metrics = json.loads(metrics_file.read_text())
    assert metrics["episodes"] == 1 and metrics["mean_episode_length_s"] <= 1.0 + 1e-9


def test_play_records_a_usd_stage_with_one_sample_per_step(tmp_path):
    from pxr import Usd

    stage_path = tmp_path / "rollout.usda"
    code, out = run("scripts/play.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--num_steps", "7",
                    "--device", "cpu", "--usd", str(stage_path), *FLAT_GROUND_ARGS)
    assert code == 0 and stage_path.is_file(), out
    stage = Usd.Stage.Open(str(stage_path))
    samples = {a.GetNumTimeSamples() for p in stage.Traverse() for a in p.GetAttributes()
               if a.GetName() == "xformOp:orient"}
    assert samples == {7}
    assert stage.GetTimeCodesPerSecond() == 50.0


def test_play_renders_a_video_headless(tmp_path):
    import imageio.v2 as imageio

    video_path = tmp_path / "rollout.mp4"
    code, out = run("scripts/play.py", "--task", "Velocity-G1-History-v0", "--num_envs", "1", "--num_steps", "6",
                    "--device", "cpu", "--video", str(video_path), *FLAT_GROUND_ARGS)
    assert code == 0 and video_path.is_file(), out
    frames = [frame for frame in imageio.get_reader(str(video_path))]  # list() trips on its infinite len()
    assert len(frames) == 6 and frames[0].shape == (480, 640, 3)
    assert frames[-1].std() > 5.0  # not blank
    # the robot (green) is in the middle of the frame: the camera follows it and the ray tracer does not cull it
    centre = frames[-1][140:340, 220:420].astype(int)
    assert ((centre[..., 1] - centre[..., 0]) > 30).sum() > 2000


def test_train_records_clips_every_n_iterations(tmp_path):
    # a recurrent policy: its 1-env clips must leave the training rollout's hidden state (2 envs) as it was
    code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--max_iterations", "2",
                    "--device", "cpu", "--log_root", str(tmp_path), "--video", "--video_interval", "1",
                    "--video_length", "3", "--rnn", "gru", "agent.num_steps_per_env=4", "agent.actor.rnn_hidden_dim=16",
                    "agent.critic.rnn_hidden_dim=16", *FLAT_GROUND_ARGS)
    assert code == 0, out
    run_dir = next((tmp_path / "velocity_t1").iterdir())
    assert sorted(p.name for p in (run_dir / "videos").iterdir()) == ["iteration_1.mp4", "iteration_2.mp4"]
    policy = yaml.safe_load((run_dir / "exported" / "io_descriptor.yaml").read_text())["policy"]
    assert policy["recurrent"] and policy["rnn_type"] == "gru" and policy["rnn_hidden_dim"] == 16


def test_train_progress_bar_shows_the_eta_and_a_full_block_every_n_iterations(tmp_path):
    code, out, err = run_split("scripts/train.py", "--task", "Velocity-T1-v0", "--num_envs", "2", "--max_iterations",
                               "3", "--device", "cpu", "--log_root", str(tmp_path), "--progress", "bar",
                               "--full_log_every", "2", "agent.num_steps_per_env=4", *FLAT_GROUND_ARGS)
    assert code == 0, out + err
    bar = err.replace("\r", "\n").splitlines()
    assert any("training: 100%" in line and "3/3" in line and "iteration=2" in line for line in bar), err
    assert any("training:  33%" in line and "<" in line for line in bar), err  # elapsed<remaining: the ETA
    blocks = [line for line in out.splitlines() if "Learning iteration" in line]
    assert len(blocks) == 1 and "Learning iteration 1/3" in blocks[0], out  # the 2nd of 3 iterations only


@pytest.mark.skipif(__import__("warp").is_cuda_available(), reason="the CPU fallback is what this checks")
@pytest.mark.parametrize("num_envs, said", [(None, "running on CPU with 4 envs (a small count"),
                                            (64, "running on CPU with 64 envs\n"), (1, "running on CPU with 1 env\n")])
def test_the_cpu_fallback_says_the_env_count_it_builds(num_envs, said, capsys):
    from agile.run import task_setup

    env_cfg, _, device = task_setup.load_task(task="Velocity-T1-v0", num_envs=num_envs)
    assert device == "cpu" and env_cfg.num_envs == (num_envs or task_setup.CPU_DEFAULT_NUM_ENVS)
    assert f"no GPU found: {said}" in capsys.readouterr().out
