"""Teacher-student distillation as a user runs it (CPU, 2 envs): a teacher trained by PPO for one iteration,
each student distilled from it for one iteration, from its TorchScript export or its checkpoint, and the
exported student acting as the trained one."""

import math
import sys
from pathlib import Path

import pytest
from commands import FLAT_GROUND_ARGS, run_command
import torch
import yaml

ROOT = Path(__file__).resolve().parents[1]

TEACHER = "Velocity-Height-G1-Teacher-v0"
STUDENTS = {"Velocity-Height-G1-Student-Recurrent-v0": "velocity_height_g1_student_recurrent",
            "Velocity-Height-G1-Student-History-v0": "velocity_height_g1_student_history"}
"""Distillation, fine-tuning and export do not depend on the ground, and a rough terrain takes seconds to build on a
CPU (the shipped students' rollouts on their terrain are checked by tests/test_policy_fingerprints.py)."""
SHORT = ["--num_envs", "2", "--max_iterations", "1", "--device", "cpu", "agent.num_steps_per_env=15", *FLAT_GROUND_ARGS]


def run(script, *args):
    """(exit code, stdout and stderr) of `python scripts/<command>.py ARGS`, in this process."""
    code, out, err = run_command(Path(script).stem, *args, cwd=ROOT)
    return code, out + err


@pytest.fixture(scope="module")
def teacher_run(tmp_path_factory) -> Path:
    log_root = tmp_path_factory.mktemp("teacher")
    code, out = run("scripts/train.py", "--task", TEACHER, "--log_root", str(log_root), *SHORT)
    assert code == 0, out
    return next((log_root / "velocity_height_g1_teacher").iterdir())


@pytest.mark.parametrize("student", sorted(STUDENTS))
def test_one_distillation_iteration_and_its_export(student, teacher_run, tmp_path):
    code, out = run("scripts/train.py", "--task", student, "--log_root", str(tmp_path),
                    "--teacher", str(teacher_run / "exported" / "policy.pt"), *SHORT)
    assert code == 0, out
    assert "Mean behavior loss:" in out, out
    run_dir = next((tmp_path / STUDENTS[student]).iterdir())
    checkpoint = torch.load(run_dir / "model_0.pt", weights_only=True)
    # the TorchScript teacher's weights are the PPO actor's
    actor = torch.load(teacher_run / "model_0.pt", weights_only=True)["actor_state_dict"]
    for key, value in checkpoint["teacher_state_dict"].items():
        if not key.startswith("distribution."):
            torch.testing.assert_close(value, actor[key], rtol=0.0, atol=0.0)
    if student.endswith("History-v0"):
        assert "Mean mirror loss:" in out, out  # the mirror loss is logged
    # the exported student acts as the trained one, hidden state included, over several steps
    descriptor = yaml.safe_load((run_dir / "exported" / "io_descriptor.yaml").read_text())
    assert descriptor["observation_groups"] == ["policy"]
    assert [a["name"] for a in descriptor["actions"]] == ["joint_pos"]  # no harness, no random arms
    assert descriptor["policy"]["recurrent"] == student.endswith("Recurrent-v0")
    exported = torch.jit.load(str(run_dir / "exported" / "policy.pt"))
    from agile.rl import policy_obs_set
    from agile.run import task_setup
    
    import agile.tasks

    env_cfg, agent_cfg = agile.tasks.load_cfgs(student)
    env_cfg.num_envs = 1
    env = task_setup.make_env(task=student, env_cfg=env_cfg, device="cpu")
    student_policy = task_setup.load_runner(checkpoint, env, agent_cfg).get_inference_policy(device="cpu")
    assert policy_obs_set(agent_cfg) == "student"
    exported.reset()
    from agile.rl import flatten_groups

    obs, _ = env.reset()
    with torch.inference_mode():
        for _ in range(5):
            flat = flatten_groups(obs)
            expected = student_policy(flat)
            torch.testing.assert_close(exported(flat["policy"]), expected, rtol=0.0, atol=1e-5)
            obs, *_ = env.step(expected)
    env.close()


FINETUNES = {"Velocity-Height-G1-Student-Recurrent-Finetune-v0": "Velocity-Height-G1-Student-Recurrent-v0",
             "Velocity-Height-G1-Student-History-Finetune-v0": "Velocity-Height-G1-Student-History-v0"}


@pytest.mark.parametrize("task", sorted(FINETUNES))
def test_ppo_finetuning_starts_from_the_shipped_student_and_exports(task, tmp_path):
    # one iteration of critic warm-up, then one of PPO (one mini-batch: a recurrent one takes whole envs, of 2)
    code, out = run("scripts/train.py", "--task", task, "--log_root", str(tmp_path), "--num_envs", "2",
                    "--max_iterations", "2", "--device", "cpu", "agent.num_steps_per_env=15",
                    "agent.critic_warmup_iterations=1", "agent.algorithm.num_mini_batches=1", *FLAT_GROUND_ARGS)
    assert code == 0, out
    assert f"fine-tunes {FINETUNES[task]}" in out and "Mean value loss" in out, out  # PPO, not distillation
    assert "critic warm-up: 1 iterations with the actor held, learning rate 0.001" in out, out
    run_dir = next(next(tmp_path.iterdir()).iterdir())
    student = torch.load(ROOT / "agile" / "data" / "policy" / f"{FINETUNES[task]}.pt",
                         weights_only=True)["student_state_dict"]
    started = torch.load(run_dir / "init_policy.pt", weights_only=True)["actor_state_dict"]
    assert started.keys() == student.keys()
    for key, value in student.items():
        torch.testing.assert_close(started[key], value, rtol=0.0, atol=0.0)
    warmed = torch.load(run_dir / "model_0.pt", weights_only=True)
    assert set(warmed) >= {"actor_state_dict", "critic_state_dict"} and warmed["iter"] == 0
    # through the warm-up the actor is the student exactly (its observation normaliser's statistics aside, which
    # follow the rollouts); then PPO moves it
    for key, value in student.items():
        if not key.startswith("obs_normalizer."):
            torch.testing.assert_close(warmed["actor_state_dict"][key], value, rtol=0.0, atol=0.0)
    # the warm-up trained the critic at 1e-3; PPO starts at the task's 1e-5 (the KL rule then moves it by 1.5x
    # steps, so the saved optimizer's rate is 1e-5 times a power of 1.5)
    assert warmed["optimizer_state_dict"]["param_groups"][0]["lr"] == pytest.approx(1e-3)
    tuned = torch.load(run_dir / "model_1.pt", weights_only=True)
    assert tuned["iter"] == 1
    steps = math.log(tuned["optimizer_state_dict"]["param_groups"][0]["lr"] / 1e-5, 1.5)
    assert abs(steps - round(steps)) < 1e-6 and abs(steps) <= 8, steps
    assert not torch.equal(tuned["actor_state_dict"]["mlp.0.weight"], student["mlp.0.weight"])
    assert not torch.equal(tuned["critic_state_dict"]["mlp.0.weight"], warmed["critic_state_dict"]["mlp.0.weight"])
    descriptor = yaml.safe_load((run_dir / "exported" / "io_descriptor.yaml").read_text())
    assert descriptor["observation_groups"] == ["policy"]
    assert descriptor["policy"]["recurrent"] == ("Recurrent" in task)


def test_a_shipped_student_is_distilled_further_from_its_weights(tmp_path):
    """--init_policy on a distilled task: the student starts from a distilled student's weights (here the shipped
    one, the teacher the shipped teacher) and its distillation goes on; a PPO actor is refused by name."""
    shipped = ROOT / "agile" / "data" / "policy" / "Velocity-Height-G1-Student-History-v0.pt"
    code, out = run("scripts/train.py", "--task", "Velocity-Height-G1-Student-History-v0", "--init_policy",
                    str(shipped), "--log_root", str(tmp_path), *SHORT)
    assert code == 0 and "student initialised from" in out and "Mean behavior loss:" in out, out
    run_dir = next((tmp_path / STUDENTS["Velocity-Height-G1-Student-History-v0"]).iterdir())
    student = torch.load(shipped, weights_only=True)["student_state_dict"]
    started = torch.load(run_dir / "init_policy.pt", weights_only=True)["student_state_dict"]
    distilled = torch.load(run_dir / "model_0.pt", weights_only=True)
    assert distilled["iter"] == 0  # a new run, from the shipped weights
    for key, value in student.items():
        torch.testing.assert_close(started[key], value, rtol=0.0, atol=0.0)
    assert not torch.equal(distilled["student_state_dict"]["mlp.0.weight"], student["mlp.0.weight"])  # it learned
    assert torch.dist(distilled["student_state_dict"]["mlp.0.weight"], student["mlp.0.weight"]) < 1.0  # from there
    actor = ROOT / "agile" / "data" / "policy" / "Velocity-Height-G1-Teacher-v0.pt"
    code, out = run("scripts/train.py", "--task", "Velocity-Height-G1-Student-History-v0", "--init_policy",
                    str(actor), "--log_root", str(tmp_path), *SHORT)
    assert code != 0 and "starts from a distilled student (its student_state_dict)" in out, out


def test_finetuning_refuses_a_checkpoint_without_a_policy(tmp_path):
    bad = tmp_path / "critic_only.pt"
    torch.save({"critic_state_dict": {}, "iter": 3}, bad)
    code, out = run("scripts/train.py", "--task", "Velocity-Height-G1-Student-History-Finetune-v0", "--init_policy",
                    str(bad), "--log_root", str(tmp_path), *SHORT)
    assert code != 0 and "no actor_state_dict or student_state_dict in it" in out, out


def test_a_student_without_a_teacher_is_refused_in_one_line(tmp_path):
    code, out = run("scripts/train.py", "--task", "Velocity-Height-G1-Student-History-v0", "--log_root",
                    str(tmp_path), "--teacher", str(tmp_path / "missing.pt"), *SHORT)
    assert code == 2 and "--teacher file not found" in out, out
    shipped = Path(__file__).resolve().parents[1] / "agile" / "data" / "policy" / "Velocity-T1-v0.pt"
    code, out = run("scripts/train.py", "--task", "Velocity-T1-v0", "--teacher", str(shipped), *SHORT)
    assert code == 2 and "trained by PPO" in out, out


def test_eval_reports_the_height_error_and_sweeps_velocity_by_height(teacher_run, tmp_path):
    out = tmp_path / "sweep.json"
    code, log = run("scripts/eval.py", "--task", TEACHER, "--checkpoint", str(teacher_run / "model_0.pt"),
                    "--device", "cpu", "--num_envs", "4", "--episode_length_s", "0.2", "--sweep_lin_vel_x", "0", "0.5",
                    "--sweep_base_height", "0.5", "0.72", "--out", str(out), *FLAT_GROUND_ARGS)
    assert code == 0, log
    import json

    result = json.loads(out.read_text())
    assert [cell["command"] for cell in result["cells"]] == [[0.0, 0.0, 0.0, 0.5], [0.5, 0.0, 0.0, 0.5],
                                                           [0.0, 0.0, 0.0, 0.72], [0.5, 0.0, 0.0, 0.72]]
    for cell in result["cells"]:
        assert cell["num_envs"] == 1 and 0.0 <= cell["base_height_error_m"] < 1.0
    assert "| vx [m/s] | height [m] | fall rate |" in log


def test_a_fixed_command_holds_through_resampling_resets_and_smoothing():
    sys.path.insert(0, str(ROOT / "tests"))
    from fakes import FakeEnv

    from agile.rl_env import mdp

    env = FakeEnv(num_envs=2)
    term = mdp.UniformVelocityBaseHeightCommand(mdp.UniformVelocityBaseHeightCommandCfg(ema_smoothing=0.5), env)
    fixed = torch.tensor([[0.5, 0.0, 0.0, 0.72], [0.0, 0.0, 0.0, 0.45]])
    term.set_fixed_command(fixed)
    for _ in range(3):
        term.time_left_s[:] = 0.0  # resample every step: the drawn commands must not show
        term.compute(0.02)
        torch.testing.assert_close(term.command, fixed)
    term.reset(torch.ones(2, dtype=torch.bool))
    torch.testing.assert_close(term.command, fixed)
    term.set_fixed_command(None)
    term.time_left_s[:] = 0.0
    term.compute(0.02)
    assert not torch.equal(term.command, fixed)  # drawing again
    with pytest.raises(ValueError, match="this command is"):
        term.set_fixed_command(torch.zeros(3))
