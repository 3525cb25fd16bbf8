"""The task catalogue and the `agile` command line (issue 25): list, show, diff, forwarding, unknown tasks."""

from __future__ import annotations

import subprocess
import sys

import pytest
from commands import run_main

import agile.tasks
from agile.cli import main as cli_main
from agile.rl import DistillationRunnerCfg
from agile.tasks.catalogue import DEFAULT_CRITERIA, catalogue, evaluated_tasks, missed_criteria
from agile.tasks.describe import MISSING, config_diff, task_config_tree

T1, G1 = "Velocity-T1-v0", "Velocity-G1-History-v0"


def run_agile(*args: str) -> subprocess.CompletedProcess:
    """`agile ARGS`, run in this process (`agile.tasks.main`): its exit code, stdout and stderr."""
    code, out, err = run_main(cli_main, *args)
    return subprocess.CompletedProcess(["agile", *args], code, out, err)


def test_catalogue_kinds_come_from_the_registry():
    entries = {e.task: e for e in catalogue()}
    assert sorted(entries) == agile.tasks.registered_tasks()
    for task, e in entries.items():
        distilled = isinstance(agile.tasks.load_cfgs(task)[1], DistillationRunnerCfg)
        expected = "distilled" if distilled else agile.tasks.task_kind(task)
        assert e.kind == expected, task
        assert e.policy == agile.tasks.pretrained_policy(task)
    assert entries["Velocity-Height-G1-Student-History-v0"].kind == "distilled"
    assert entries["Debug-G1-v0"].kind == "debug" and entries["Debug-G1-v0"].criteria == {}
    assert entries["MultiRate-G1-T1-Velocity-v0"].kind == "multi_agent"
    # a height command adds the height criterion; the plain velocity tasks have none
    assert "base_height_error_m" in entries["Velocity-Height-G1-v0"].criteria
    assert "base_height_error_m" not in entries[T1].criteria
    # every task with a policy of its own (a second ID sharing the file is evaluated under the file's name), a
    # multi-agent task's folder of group checkpoints included; a multi-agent task's criteria bound each agent
    assert {e.task for e in evaluated_tasks()} == {
        t for t, e in entries.items()
        if e.kind in ("trainable", "distilled", "multi_agent") and e.policy is not None
        and e.policy.stem.split(".")[0] == t}
    assert entries["MultiRate-G1-T1-Velocity-v0"].criteria == DEFAULT_CRITERIA
    assert "Velocity-Height-G1-v0" not in {e.task for e in evaluated_tasks()}
    assert {T1, G1, "MotionTracking-G1-v0"} <= {e.task for e in evaluated_tasks()}
    assert "Tracking-Flat-G1-v0" not in {e.task for e in evaluated_tasks()}
    # a task without a velocity command is held to its falls and its own command metrics
    assert entries["MotionTracking-G1-v0"].criteria == {"fall_rate": 0.05, "motion/body_pos_error_m": 0.05,
                                                        "motion/joint_pos_error_rad": 0.1}


def test_missed_criteria():
    criteria = {"fall_rate": 0.05, "base_height_error_m": 0.05}
    assert missed_criteria({"fall_rate": 0.01, "base_height_error_m": 0.02}, criteria) == []
    assert missed_criteria({"fall_rate": 0.2, "base_height_error_m": 0.02}, criteria) == ["fall_rate 0.2 > 0.05"]
    assert missed_criteria({"fall_rate": float("nan"), "base_height_error_m": 0.0}, criteria) == ["fall_rate nan > 0.05"]
    assert missed_criteria({"fall_rate": 0.0}, criteria) == ["base_height_error_m not measured (maximum 0.05)"]
    # episode metrics (a command's "<term>/<name>", a metric term's "<name>") are looked up among eval.py's
    # episode_metrics; in a JSON written before the metric terms, among its command_metrics
    assert missed_criteria({"fall_rate": 0.0, "episode_metrics": {"motion/joint_pos_error_rad": 0.2}},
                           {"motion/joint_pos_error_rad": 0.1}) == ["motion/joint_pos_error_rad 0.2 > 0.1"]
    assert missed_criteria({"episode_metrics": {"not_standing_at_time_out": 0.05}},
                           {"not_standing_at_time_out": 0.1}) == []
    assert missed_criteria({"command_metrics": {"motion/joint_pos_error_rad": 0.2}},
                           {"motion/joint_pos_error_rad": 0.1}) == ["motion/joint_pos_error_rad 0.2 > 0.1"]
    # minima: shares of success (the cube lifted), missed below them or when not measured
    minima = {"reference/object_lifted": 0.8}
    assert missed_criteria({"episode_metrics": {"reference/object_lifted": 0.9}}, {}, minima) == []
    assert missed_criteria({"episode_metrics": {"reference/object_lifted": 0.5}}, {}, minima) == [
        "reference/object_lifted 0.5 < 0.8"]
    assert missed_criteria({}, {}, minima) == ["reference/object_lifted not measured (minimum 0.8)"]
    # a maximum on one of eval.py's error_by_command breakdowns bounds every bin with steps (HeightTracking-G1: the
    # height error in each commanded-height band), each missing bin named; a breakdown not measured is a miss
    bins = {"error_by_command": {"height_error_m_by_height_m": [
        {"command": [0.0, 0.2], "error": 0.047, "steps": 6136}, {"command": [0.2, 0.4], "error": 0.098, "steps": 8367},
        {"command": [0.8, 0.9], "error": 0.3, "steps": 0}, {"command": [0.9, None], "error": 0.053, "steps": 26018}]}}
    assert missed_criteria(bins, {"height_error_m_by_height_m": 0.05}) == [
        "height_error_m_by_height_m [0.2, 0.4) 0.098 > 0.05", "height_error_m_by_height_m [0.9, ) 0.053 > 0.05"]
    assert missed_criteria(bins, {"height_error_m_by_height_m": 0.1}) == []
    assert missed_criteria({}, {"height_error_m_by_height_m": 0.05}) == [
        "height_error_m_by_height_m not measured (maximum 0.05)"]


def test_pick_place_and_height_tracking_carry_their_issues_figures():
    from agile.tasks.catalogue import task_entry

    pick_place = task_entry("PickPlace-G1-v0")
    assert pick_place.criteria == {"fall_rate": 0.05, "reference/joint_pos_error_rad": 0.1}
    assert pick_place.minima == {"reference/object_lifted": 0.8, "reference/object_at_goal": 0.6}
    assert (pick_place.eval_settings["num_envs"], pick_place.eval_settings["episode_length_s"]) == (256, 8.0)
    height = task_entry("HeightTracking-G1-v0")
    assert height.criteria == {"fall_rate": 0.05, "height/height_error_m": 0.05, "height_error_m_by_height_m": 0.05}
    assert not height.minima


# What agile/tasks/velocity/t1/velocity_env_cfg.py and g1/velocity_history_env_cfg.py set differently (the shared
# blocks of velocity_common.py with the robot's bodies and numbers as arguments), and the T1 runner's init std
# (docs/agile_differences.md), as key paths three deep.
EXPECTED_T1_G1_DIFF = {
    # scene: the robot model, the terrain preset, the sensed bodies, the base body of the height ray
    "env.scene.entities", "env.scene.terrain", "env.scene.contact_sensors", "env.scene.height_scanners",
    "env.sim.solver",  # max contacts per world
    # actions: controlled joints, scale, clip; the joints the random arm motions leave alone
    "env.actions.joint_pos", "env.actions.random_pos",
    "env.observations.policy",  # the controlled joints
    # rewards whose weight, params or function differ (termination, velocity tracking are the same)
    "env.rewards.base_height", "env.rewards.orientation", "env.rewards.lin_vel_z", "env.rewards.ang_vel_xy",
    "env.rewards.root_acc", "env.rewards.collision", "env.rewards.jumping", "env.rewards.torques",
    "env.rewards.ankle_torques", "env.rewards.ankle_roll_torques", "env.rewards.dof_vel", "env.rewards.dof_pos_limits",
    "env.rewards.dof_vel_limits", "env.rewards.torque_limits", "env.rewards.action_rate",
    "env.rewards.action_rate_rate", "env.rewards.feet_slip", "env.rewards.feet_roll", "env.rewards.feet_yaw_diff",
    "env.rewards.feet_yaw_mean", "env.rewards.feet_distance",
    # terminations: trunk bodies, the base-height target
    "env.terminations.illegal_ground_contact", "env.terminations.illegal_base_height",
    # events: the base body, its mass and CoM ranges, the extremities
    "env.events.base_mass", "env.events.base_com", "env.events.base_external_wrench",
    "env.events.extremities_external_wrench",
    "env.curriculum.action_rate", "env.curriculum.action_rate_rate",  # final action-rate weights
    "agent.experiment_name", "agent.max_iterations", "agent.actor.distribution_cfg",  # T1: 100k iterations, init std 0.3
}


def test_diff_t1_g1_history_lists_what_the_task_files_imply():
    diff = config_diff(task_config_tree(T1), task_config_tree(G1))
    assert {".".join(path.split(".")[:3]) for path in diff} == EXPECTED_T1_G1_DIFF
    # the values the two files set
    assert diff["env.rewards.base_height.weight"] == (2.0, 2.5)
    assert diff["env.rewards.orientation.func"][1].endswith(":flat_body_orientation_exp")
    assert diff["env.rewards.collision"][1] == MISSING and diff["env.rewards.jumping"][0] == MISSING
    assert diff["env.actions.joint_pos.scale"] == (1.0, 0.5)
    assert diff["env.sim.solver.nconmax"] == (128, 256)
    assert diff["agent.actor.distribution_cfg.init_std"] == (0.3, 1.0)
    assert "env.rewards.ankle_torques.weight" not in diff  # same weight, other joint regex
    assert config_diff(task_config_tree(T1), task_config_tree(T1)) == {}


def test_cli_diff_list_and_unknown_task():
    result = run_agile("diff", T1, G1)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("# ") and "env.rewards.base_height.weight: 2.0 -> 2.5" in lines
    assert not any(line.startswith("env.rewards.track_lin_vel_xy_exp") for line in lines)
    result = run_agile("show", "Velocity-Nope-v0")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "unknown task 'Velocity-Nope-v0'" in result.stderr
    assert all(task in result.stderr for task in agile.tasks.registered_tasks())
    result = run_agile("list")
    assert result.returncode == 0
    rows = {line.split()[0]: line.split()[1:] for line in result.stdout.splitlines()[1:]}
    assert rows[T1] == ["trainable", f"{T1}.pt"] and rows["Debug-T1-v0"] == ["debug", "-"]


def test_python_m_agile_is_the_command_line():
    """The module entry point in a fresh interpreter (the process is the point; the other tests call its main)."""
    result = subprocess.run([sys.executable, "-m", "agile", "list"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stdout.split()[:4] == ["task", "kind", "shipped", "policy"], result.stderr


@pytest.mark.parametrize("script", ["train", "eval_all"])  # one forwarding path; each script tests its own --help
def test_cli_forwards_help_to_the_scripts(script):
    result = run_agile(script, "--help")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"usage: agile {script}")


def test_show_resolves_regexes_dims_and_actuators():
    import yaml

    result = run_agile("show", T1)
    assert result.returncode == 0, result.stderr
    mdp = yaml.safe_load(result.stdout)
    legs = mdp["actions"]["joint_pos"]["joints"]
    assert len(legs) == 12 and all(any(k in j for k in ("Hip", "Knee", "Ankle")) for j in legs)
    assert mdp["rewards"]["ankle_roll_torques"]["params"]["asset_cfg"]["joints"] == ["Left_Ankle_Roll", "Right_Ankle_Roll"]
    assert mdp["rewards"]["ankle_roll_torques"]["weight"] == -2.0e-3
    policy = mdp["observations"]["policy"]
    # 5 steps of: ang vel 3, gravity 3, command 3, 12 joint pos, 12 joint vel, 12 actions
    assert policy["dim"] == 5 * (3 + 3 + 3 + 12 + 12 + 12) == sum(t["dim"] for t in policy["terms"].values())
    actuators = mdp["actuators"]["robot"]
    assert list(actuators) == mdp["scene"]["entities"]["robot"]["joints"]
    assert all(a["group"] is not None and a["stiffness_nm_per_rad"] > 0 for a in actuators.values())


def test_cli_forwards_fingerprint_and_its_errors(capsys):
    """`agile fingerprint` is agile/run/fingerprint.py's main: an unknown policy file is refused, naming the shipped."""
    from agile.cli import main

    assert main(["fingerprint", "--check", "Nope-v0.pt"]) == 2
    err = capsys.readouterr().err
    assert "not shipped policies: ['Nope-v0.pt']" in err and "Velocity-T1-v0.pt" in err


def test_overrides_may_come_before_between_and_after_options():
    """A command line built in parts (a test's flat-ground overrides, then options, then one more override) parses;
    argparse's plain parse_args refused the second group of overrides ("unrecognized arguments")."""
    from agile.run import arguments as common

    parser = common.new_parser("test")
    common.add_common_args(parser)
    common.add_recipe_arg(parser)
    parser.add_argument("--max_iterations", type=int, default=None)
    args = common.parse(parser, ["--task", T1, "env.a=1", "--max_iterations", "3", "agent.b=2", "--recipe", "fast"])
    assert args.max_iterations == 3 and args.task == T1
    assert args.overrides[-2:] == ["env.a=1", "agent.b=2"]  # after the recipe's, which they override
