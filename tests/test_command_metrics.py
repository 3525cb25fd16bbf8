"""Command metrics (`CommandTerm.metrics`): the manager keeps the ended episodes' values and logs their means; the
motion-tracking errors and the pick-and-place success against hand-computed values on scripted states; eval.py
reports them for both tasks."""

import json
import math

import gymnasium as gym
import pytest
import torch
from commands import FLAT_GROUND
from fakes import FakeEnv

import agile.tasks
from agile.rl_env.managers import CommandManager, CommandTerm
from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict
from agile.utils.config import configclass

# -- the mechanism, on a fake term ----------------------------------------------------------------------------


class CountingCommand(CommandTerm):
    """A command whose metrics are the mean of a per-step value (`step_value_m`) and an end-of-episode value."""

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        self._command = torch.zeros(env.num_envs, 1)
        self.step_value_m = torch.zeros(env.num_envs)
        self._mean = self._episode_mean("mean_m")
        self.metrics["final_m"] = torch.zeros(env.num_envs)

    @property
    def command(self):
        return self._command

    def _resample(self, env_mask):
        pass

    def update_metrics(self):
        self._mean.add(self.step_value_m)

    def finish_episodes(self, env_mask):
        self.metrics["final_m"].copy_(torch.where(env_mask, self.step_value_m * 10.0, self.metrics["final_m"]))


@configclass
class CountingCommandCfg:
    class_type: type = CountingCommand
    resampling_time_range_s: tuple[float, float] = (1.0e9, 1.0e9)


@configclass
class Commands:
    count = CountingCommandCfg()


def test_manager_keeps_the_ended_episodes_metrics_and_logs_their_mean():
    env = FakeEnv(3)
    manager = CommandManager(Commands(), env)
    term = manager.get_term("count")
    manager.reset(torch.ones(3, dtype=torch.bool))
    for values in ([1.0, 2.0, 3.0], [3.0, 4.0, 5.0]):
        term.step_value_m.copy_(torch.tensor(values))
        manager.update_metrics()
    torch.testing.assert_close(term.metrics["mean_m"], torch.tensor([2.0, 3.0, 4.0]))
    ending = torch.tensor([True, False, True])
    log = manager.finish_episodes(ending)
    last = manager.last_episode_metrics
    torch.testing.assert_close(last["count/mean_m"], torch.tensor([2.0, 0.0, 4.0]))  # env 1 goes on: not copied
    torch.testing.assert_close(last["count/final_m"], torch.tensor([30.0, 0.0, 50.0]))
    assert float(log["Metrics/count/mean_m"]) == pytest.approx(3.0)  # over the ending envs only
    assert float(log["Metrics/count/final_m"]) == pytest.approx(40.0)
    # the ended envs start afresh; the kept values stay until those envs end again
    manager.reset(ending)
    torch.testing.assert_close(term.metrics["mean_m"], torch.tensor([0.0, 3.0, 0.0]))
    term.step_value_m.fill_(1.0)
    manager.update_metrics()
    torch.testing.assert_close(term.metrics["mean_m"], torch.tensor([1.0, 2.0 + 1.0 / 3.0, 1.0]))
    torch.testing.assert_close(last["count/mean_m"], torch.tensor([2.0, 0.0, 4.0]))
    term.step_value_m.copy_(torch.tensor([float("nan"), 1.0, float("inf")]))  # a blown-up world does not count
    manager.update_metrics()
    torch.testing.assert_close(term.metrics["mean_m"], torch.tensor([1.0, 2.0, 1.0]))
    log = manager.finish_episodes(torch.zeros(3, dtype=torch.bool))
    assert float(log["Metrics/count/mean_m"]) == 0.0


def test_manager_refuses_a_metric_of_the_wrong_shape_or_added_late():
    env = FakeEnv(2)
    manager = CommandManager(Commands(), env)
    manager.get_term("count").metrics["late_m"] = torch.zeros(2)
    with pytest.raises(RuntimeError, match=r"command 'count': metrics\['late_m'\] appeared after"):
        manager.finish_episodes(torch.ones(2, dtype=torch.bool))

    class Bad(CountingCommand):
        def __init__(self, cfg, env):
            super().__init__(cfg, env)
            self.metrics["per_body_m"] = torch.zeros(env.num_envs, 3)

    with pytest.raises(ValueError, match=r"metrics\['per_body_m'\] must be a float tensor of one value per env"):
        CommandManager(Commands(count=CountingCommandCfg(class_type=Bad)), env)


# -- motion tracking --------------------------------------------------------------------------------------------

def checkpoint_of_untrained_policy(env, task: str, path) -> str:
    """A checkpoint of the task's runner as built (untrained): what eval.py loads."""
    _, agent_cfg = agile.tasks.load_cfgs(task)
    from rsl_rl.runners import OnPolicyRunner

    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=None, device="cpu")
    runner.save(str(path))
    return str(path)


def run_eval(task: str, checkpoint: str, out) -> dict:
    from agile.run import eval as eval_script

    eval_script.main(["--task", task, "--checkpoint", checkpoint, "--device", "cpu", "--num_envs", "2",
                      "--episode_length_s", "0.2", "--out", str(out)])
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def motion_env():
    overrides = ["commands.motion.pose_range={}", "commands.motion.velocity_range={}",
                 "commands.motion.joint_position_range=(0.0, 0.0)"]
    env = gym.make("MotionTracking-G1-v0", num_envs=2, device="cpu", overrides=overrides).unwrapped
    yield env
    env.close()


def test_motion_errors_are_zero_in_the_reference_and_hand_computed_for_an_offset(motion_env):
    env = motion_env
    env.reset()
    cmd = env.command_manager.get_term("motion")
    robot = cmd.robot
    cmd.update_metrics()  # the robot was written exactly into the reference state
    assert cmd.metrics["body_pos_error_m"].abs().max() < 1e-4
    assert cmd.metrics["joint_pos_error_rad"].abs().max() < 1e-6
    # env 0: the wrist yaw joint 0.2 rad off (it turns the hand about its own origin: no tracked body moves) and
    # the whole robot 10 cm forward, which the anchor-relative targets follow, and 5 cm up, which they do not
    # (they keep the reference height): every tracked body 5 cm off
    only_0 = torch.tensor([True, False])
    joint_pos = robot.joint_pos.clone()
    joint_pos[0, robot.joint_names.index("left_wrist_yaw_joint")] += 0.2
    robot.write_joint_state(joint_pos, robot.joint_vel.clone(), only_0)
    pose = robot.root_pose_w.clone()
    pose[0, :3] += torch.tensor([0.1, 0.0, 0.05])
    robot.write_root_state(pose, robot.root_com_vel_w.clone(), only_0)
    env.sim.forward(only_0)
    robot.update()
    cmd._update_command()
    cmd.update_metrics()
    joints = len(robot.joint_names)
    assert joints == 29
    # means over the two steps
    torch.testing.assert_close(cmd.metrics["body_pos_error_m"], torch.tensor([0.025, 0.0]), atol=1e-4, rtol=0)
    torch.testing.assert_close(cmd.metrics["joint_pos_error_rad"], torch.tensor([0.1 / joints, 0.0]),
                               atol=1e-6, rtol=0)
    log = env.command_manager.finish_episodes(only_0)
    assert float(log["Metrics/motion/body_pos_error_m"]) == pytest.approx(0.025, abs=1e-4)
    last = env.command_manager.last_episode_metrics["motion/joint_pos_error_rad"]
    assert float(last[0]) == pytest.approx(0.1 / joints, abs=1e-6)


def test_motion_metrics_reach_the_training_log(motion_env):
    env = motion_env
    env.reset()
    _, _, _, _, extras = env.step(torch.zeros(2, env.action_manager.total_action_dim))
    assert {"Metrics/motion/body_pos_error_m", "Metrics/motion/joint_pos_error_rad"} <= set(extras["log"])


def test_eval_reports_motion_tracking_errors(motion_env, tmp_path):
    checkpoint = checkpoint_of_untrained_policy(motion_env, "MotionTracking-G1-v0", tmp_path / "model.pt")
    metrics = run_eval("MotionTracking-G1-v0", checkpoint, tmp_path / "eval.json")
    assert set(metrics["episode_metrics"]) == {"motion/body_pos_error_m", "motion/joint_pos_error_rad"}
    assert metrics["episodes"] >= 2 and "fall_rate" in metrics
    assert all(0.0 < v < 1.0 for v in metrics["episode_metrics"].values()), metrics["episode_metrics"]
    assert "lin_vel_error_mps" not in metrics and metrics["error_by_command"] == {}  # no velocity command
    assert "episodes_by_variant" not in metrics  # one motion: no kinds of episode


def test_eval_breaks_outcomes_down_by_the_kind_of_episode_each_started_with():
    from agile.run.metric_breakdowns import OutcomesByVariant

    class Term:  # a command drawing one of two kinds of episode per env
        ids = torch.tensor([0, 1, 1])

        def episode_variants(self):
            return ["a", "b"], self.ids

    term = Term()
    outcomes = OutcomesByVariant(term.episode_variants, ["m"])
    # env 1 (kind b) falls with m = 2; its reset draws kind a
    done = torch.tensor([False, True, False])
    term.ids = torch.tensor([0, 0, 1])
    outcomes.add(done, done, {"m": torch.tensor([0.0, 2.0, 0.0])})
    # every episode times out: env 1's second episode counts for kind a
    done = torch.ones(3, dtype=torch.bool)
    outcomes.add(done, torch.zeros(3, dtype=torch.bool), {"m": torch.tensor([1.0, 3.0, 5.0])})
    rows = {row["variant"]: row for row in outcomes.rows()}
    assert (rows["a"]["episodes"], rows["a"]["falls"], rows["a"]["episode_metrics"]["m"]) == (2, 0, 2.0)
    assert (rows["b"]["episodes"], rows["b"]["falls"], rows["b"]["fall_rate"]) == (2, 1, 0.5)
    assert rows["b"]["episode_metrics"]["m"] == 3.5


# -- pick and place ---------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def pick_place_env():
    env = gym.make("PickPlace-G1-v0", num_envs=2, device="cpu").unwrapped
    yield env
    env.close()


def place_object(env, positions_w: torch.Tensor) -> None:
    obj = env.scene["object"]
    pose = obj.root_pose_w.clone()
    pose[:, :3] = positions_w
    all_envs = torch.ones(env.num_envs, dtype=torch.bool)
    obj.write_root_state(pose, torch.zeros_like(obj.root_com_vel_w), all_envs)
    env.sim.forward(all_envs)
    obj.update()


def test_pick_place_lift_and_goal_metrics_on_scripted_object_poses(pick_place_env):
    env = pick_place_env
    env.reset()
    cmd = env.command_manager.get_term("reference")
    start = env.scene["object"].root_pos_w.clone()
    torch.testing.assert_close(cmd.object_start_height_m, start[:, 2])
    up = torch.tensor([0.0, 0.0, 1.0])
    place_object(env, start + 0.01 * up)  # both 1 cm up: within the margin (a rocked cube), no lift
    cmd.update_metrics()
    assert cmd.metrics["object_lifted"].tolist() == [0.0, 0.0]
    place_object(env, start + torch.tensor([[0.0], [0.03]]) * up)  # env 1 3 cm up: lifted
    cmd.update_metrics()
    place_object(env, start)  # back down: env 1 was lifted during the episode all the same
    cmd.update_metrics()
    assert cmd.metrics["object_lifted"].tolist() == [0.0, 1.0]
    # at the end, env 0 3 cm beside and 3 cm above the goal (4.2 cm: at it), env 1 6 cm beside it
    goal = cmd.goal_object_pos_w
    place_object(env, goal + torch.tensor([[0.03, 0.0, 0.03], [0.0, -0.06, 0.0]]))
    log = env.command_manager.finish_episodes(torch.ones(2, dtype=torch.bool))
    last = env.command_manager.last_episode_metrics
    torch.testing.assert_close(last["reference/object_goal_distance_m"],
                               torch.tensor([0.03 * math.sqrt(2), 0.06]), atol=1e-5, rtol=0)
    assert last["reference/object_at_goal"].tolist() == [1.0, 0.0]
    assert last["reference/object_lifted"].tolist() == [0.0, 1.0]
    assert float(log["Metrics/reference/object_at_goal"]) == 0.5
    # the goal is the trajectory's last object position
    ids = cmd.trajectory_ids
    torch.testing.assert_close(goal, cmd.ref_object_pos[ids, cmd.num_frames[ids] - 1] + env.env_origins)
    assert math.isclose(cmd.cfg.lift_margin_m, 0.02) and math.isclose(cmd.cfg.goal_tolerance_m, 0.05)


def test_eval_reports_pick_place_success(pick_place_env, tmp_path):
    checkpoint = checkpoint_of_untrained_policy(pick_place_env, "PickPlace-G1-v0", tmp_path / "model.pt")
    metrics = run_eval("PickPlace-G1-v0", checkpoint, tmp_path / "eval.json")
    found = metrics["episode_metrics"]
    assert set(found) == {"reference/joint_pos_error_rad", "reference/object_lifted",
                          "reference/object_goal_distance_m", "reference/object_at_goal"}
    assert 0.0 < found["reference/joint_pos_error_rad"] < 1.0
    assert 0.0 <= found["reference/object_lifted"] <= 1.0 and 0.0 <= found["reference/object_at_goal"] <= 1.0
    # 0.2 s episodes: the cube is still near its start, 8-15 cm from any trajectory's goal
    assert 0.05 < found["reference/object_goal_distance_m"] < 0.3
    assert "lin_vel_error_mps" not in metrics
    # by trajectory: the kinds the episodes started with, every ended episode counted once
    rows = metrics["episodes_by_variant"]["reference"]
    assert {row["variant"] for row in rows} <= {"pick_place_left", "pick_place_near_left", "pick_place_right"}
    assert sum(row["episodes"] for row in rows) == metrics["episodes"]
    assert set(rows[0]["episode_metrics"]) == set(found)


def test_eval_counts_falls_by_robot():
    """An env's robot keeps its startup randomisation for the whole evaluation: one that cannot walk falls after
    every reset, so falls are also counted by robot (env), overall and within a sweep's mask."""
    from agile.run.rollout_metrics import summarise

    n = 4
    sums = {"episodes": torch.tensor([1.0, 4.0, 2.0, 1.0]), "falls": torch.tensor([0.0, 3.0, 1.0, 0.0]),
            "steps_alive": torch.full((n,), 100.0), "ended_length_steps": torch.full((n,), 100.0)}
    metrics = summarise(sums, 0.02)
    assert (metrics["falls"], metrics["robots_fallen"], metrics["max_falls_of_one_robot"]) == (4, 2, 3)
    assert metrics["robot_fall_rate"] == pytest.approx(0.5) and metrics["fall_rate"] == pytest.approx(0.5)
    masked = summarise(sums, 0.02, mask=torch.tensor([True, False, True, True]))
    assert (masked["robots_fallen"], masked["max_falls_of_one_robot"]) == (1, 1)
    assert masked["robot_fall_rate"] == pytest.approx(1 / 3)


def test_eval_counts_each_envs_first_episodes_only():
    """An env that falls starts another episode inside the evaluation's window; only its first `num_episodes` count
    (counting the rest would count their falls but not the time-outs the window cuts off). A T1 driven by large
    random actions falls within a second, several times in a 2 s window: still one episode per env."""
    from agile.run.rollout_metrics import evaluate

    env = gym.make("Velocity-T1-v0", num_envs=2, device="cpu",
                   overrides=["episode_length_s=2.0", *FLAT_GROUND]).unwrapped
    num_actions = env.action_manager.total_action_dim
    torch.manual_seed(0)
    metrics = evaluate(env, lambda obs: 20.0 * torch.randn(env.num_envs, num_actions), num_episodes=1)
    assert metrics["episodes"] == env.num_envs  # not the falls after the first ones
    assert metrics["falls"] == metrics["robots_fallen"] and metrics["falls"] >= 1
    assert metrics["max_falls_of_one_robot"] == 1
    env.close()
