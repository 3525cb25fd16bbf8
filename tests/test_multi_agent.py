"""The multi-agent world: its schedule, held targets between an agent's actions, soft death, PettingZoo's own API
tests, and shared and joint training groups."""

import copy
import warnings

import gymnasium as gym
import pytest
import torch

import agile.tasks  # noqa: F401
from agile.assets.booster_t1 import t1_robot_cfg
from agile.marl import MultiAgentEnv, MultiAgentEnvCfg, Schedule
from agile.marl.rsl_rl import AgentGroupCfg, GroupVecEnv, MultiAgentRunnerCfg
from agile.marl.runner import MultiAgentRunner
from agile.rl import flatten_groups
from agile.sim import ContactSensorCfg, HeightScannerCfg, SceneCfg
from agile.tasks.velocity.t1 import velocity_env_cfg as t1_task
from agile.tasks.velocity.t1.agents.rsl_rl_cfg import t1_velocity_ppo_runner_cfg
from agile.tasks.multi_agent.multi_rate_velocity_env_cfg import t1_agent_cfg
from agile.tasks.multi_agent.velocity_agents import TRUNK_ON_GROUND, trunk_on_ground_sensors
from agile.utils.config import ConfigError

TASK = "MultiRate-G1-T1-Velocity-v0"


def test_schedule_of_50_and_25_hz_agents():
    schedule = Schedule({"g1": 4, "t1": 8})
    assert (schedule.tick_steps, schedule.hyperperiod_steps) == (4, 8)
    assert [(s.physics_step, s.agents, s.ticks_to_next) for s in schedule.slots] == [(0, ("g1", "t1"), 1),
                                                                                     (4, ("g1",), 1)]
    assert schedule.acting_at(8) == ("g1", "t1") and schedule.acting_at(12) == ("g1",)


def test_schedule_of_periods_without_a_common_tick():
    # 100 Hz and 66.7 Hz at 200 Hz physics: ticks of one physics step, some ticks without any agent
    schedule = Schedule({"a": 2, "b": 3})
    assert (schedule.tick_steps, schedule.hyperperiod_steps) == (1, 6)
    assert [(s.physics_step, s.agents) for s in schedule.slots] == [(0, ("a", "b")), (2, ("a",)), (3, ("b",)),
                                                                     (4, ("a",))]
    assert [s.ticks_to_next for s in schedule.slots] == [2, 1, 1, 2]
    with pytest.raises(ValueError, match="agent 'b'"):
        Schedule({"a": 2, "b": 0})


@pytest.fixture(scope="module")
def world():
    world = gym.make(TASK, num_envs=2, device="cpu", seed=0).unwrapped
    yield world
    world.close()


def actions_for(world, value: float = 0.0) -> dict:
    return {a: torch.full((world.num_envs, world.agents[a].action_manager.total_action_dim), value)
            for a in world.acting_agents}


def test_the_25_hz_agent_holds_its_targets_for_two_50_hz_steps(world):
    world.reset()
    assert world.acting_agents == ("g1", "t1")
    world.step({"g1": actions_for(world)["g1"], "t1": actions_for(world, 0.5)["t1"]})
    t1, g1 = world.scene["t1"], world.scene["g1"]
    t1_targets, g1_targets = t1.joint_pos_target.clone(), g1.joint_pos_target.clone()
    assert world.acting_agents == ("g1",)  # the T1's period has not ended
    results = world.step({"g1": actions_for(world, 0.3)["g1"]})
    assert set(results) == {"g1", "t1"}  # both periods end here
    torch.testing.assert_close(t1.joint_pos_target, t1_targets)  # held through the G1's second step
    assert not torch.allclose(g1.joint_pos_target, g1_targets)
    with pytest.raises(ValueError, match=r"acting now, \['g1', 't1'\]"):
        world.step({"g1": actions_for(world)["g1"]})


def test_soft_death_freezes_one_robot_while_the_other_plays_on(world):
    world.reset()
    g1 = world.scene["g1"]
    upside_down = g1.root_pose_w.clone()
    upside_down[:, 3:7] = torch.tensor([1.0, 0.0, 0.0, 0.0])  # 180° about x: bad_orientation fires
    g1.write_root_state(upside_down, torch.zeros_like(g1.root_com_vel_w), torch.tensor([True, False]))
    world.sim.forward()
    world.scene.update()
    results = world.step(actions_for(world))
    assert results["g1"].terminated.tolist() == [True, False]
    frozen_pose = g1.root_pose_w[0].clone()
    for _ in range(4):
        results = world.step(actions_for(world))
        assert results["g1"].reward[0] == 0.0 and not results["g1"].alive[0]
        assert float(results["g1"].obs["policy"]["projected_gravity"][0].abs().sum()) == 0.0  # masked
        torch.testing.assert_close(g1.root_pose_w[0], frozen_pose)  # frozen where it died
        if "t1" in results:
            assert results["t1"].alive.all() and (results["t1"].reward != 0.0).all()  # the T1 plays on
    assert world.agents["t1"].episode_length_buf[0] > 0  # its env did not reset


def test_pettingzoo_parallel_and_aec_api_tests_pass():
    from pettingzoo.test import api_test, parallel_api_test

    from agile.marl.pettingzoo import ParallelView, SingleEnvAECView, SingleEnvParallelView

    world = gym.make(TASK, num_envs=1, device="cpu", overrides=["episode_length_s=0.2"]).unwrapped
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        parallel_api_test(SingleEnvParallelView(world), num_cycles=30)
    assert not caught, [str(w.message) for w in caught]
    api_test(SingleEnvAECView(world), num_cycles=30)

    view = ParallelView(world)  # batched: tensors, every agent in every step
    obs, infos = view.reset()
    assert infos["t1"]["acting"] and obs["t1"]["policy"].batch_size == torch.Size([1])
    obs, rewards, terminated, truncated, infos = view.step({a: torch.zeros(1, view.action_space(a).shape[0])
                                                            for a in view.agents})
    assert set(rewards) == {"g1", "t1"} and infos["g1"]["acting"] and not infos["t1"]["acting"]


def two_t1_world(num_envs: int = 2) -> MultiAgentEnv:
    """Two T1s at 25 Hz, each with Velocity-T1-v0's MDP: a homogeneous pair for shared and joint groups."""
    entities, sensors, heights, agents = {}, {}, {}, {}
    for name, y_m in (("t1_a", -1.0), ("t1_b", 1.0)):
        robot = t1_robot_cfg()
        robot.init_pos_m = (0.0, y_m, robot.init_pos_m[2])
        entities[name] = robot
        sensors[f"{name}_contacts"] = ContactSensorCfg(entity=name, body_names=["Trunk", "Waist",
                                                                                *t1_task.FOOT_BODIES])
        sensors.update(trunk_on_ground_sensors({name: ["Trunk", "Waist"]}))
        heights[f"{name}_height"] = HeightScannerCfg(entity=name, body_name="Trunk")
        agent = t1_agent_cfg()
        agent.scene_names = {"robot": name, "contact_forces": f"{name}_contacts",
                             "height_measurement_sensor": f"{name}_height",
                             TRUNK_ON_GROUND: f"{name}_{TRUNK_ON_GROUND}"}
        agent.rewards = t1_task.RewardsCfg()
        agents[name] = agent
    cfg = MultiAgentEnvCfg(num_envs=num_envs, episode_length_s=1.0, agents=agents,
                           scene=SceneCfg(entities=entities, contact_sensors=sensors, height_scanners=heights,
                                          env_spacing_m=5.0),
                           sim=copy.deepcopy(t1_task.T1VelocityEnvCfg().sim))
    return MultiAgentEnv(cfg, device="cpu")


def groups_cfg(mode: str) -> MultiAgentRunnerCfg:
    runner = t1_velocity_ppo_runner_cfg()
    runner.algorithm.num_mini_batches = 2
    if mode == "joint":
        runner.algorithm.symmetry_cfg = None
    return MultiAgentRunnerCfg(rollout_s=0.16, save_interval=1,
                               groups={"pair": AgentGroupCfg(agents=["t1_a", "t1_b"], mode=mode, runner=runner)})


def test_shared_batches_two_robots_through_one_policy(tmp_path):
    world = two_t1_world()
    runner = MultiAgentRunner(world, groups_cfg("shared"), str(tmp_path), "cpu")
    view = runner.views["pair"]
    assert (view.num_envs, view.num_actions) == (4, 12)  # separate samples: a row per robot and env
    obs = view.get_observations()
    assert obs["policy"].shape[0] == 4
    torch.testing.assert_close(obs["policy"][:2], flatten_groups(world.agents["t1_a"].obs_buf)["policy"])
    actions = torch.arange(4.0).unsqueeze(1).expand(4, 12)
    split = view.split_actions(actions)
    assert split["t1_a"][:, 0].tolist() == [0.0, 1.0] and split["t1_b"][:, 0].tolist() == [2.0, 3.0]
    runner.learn(1)
    assert list(runner.runners) == ["pair"]  # one policy, the same weights for both robots
    assert runner.runners["pair"].alg.storage.observations["policy"].shape[:2] == (4, 4)  # 4 steps x 4 rows
    assert (tmp_path / "pair" / "model_0.pt").is_file()


def test_joint_concatenates_two_robots_and_a_bad_group_is_refused():
    world = two_t1_world()
    runner = MultiAgentRunner(world, groups_cfg("joint"), None, "cpu")
    view = runner.views["pair"]
    assert (view.num_envs, view.num_actions) == (2, 24)
    assert view.get_observations()["policy"].shape[1] == 2 * world.agents["t1_a"].observation_manager.group_dims[
        "policy"]
    runner.learn(1)
    bad = groups_cfg("shared")
    bad.groups["pair"].agents = ["t1_a", "nobody"]
    with pytest.raises(ConfigError, match="nobody"):
        GroupVecEnv(world, "pair", bad.groups["pair"])
    missing = groups_cfg("shared")
    missing.groups["pair"].agents = ["t1_a"]
    with pytest.raises(ConfigError, match=r"not in any: \['t1_b'\]"):
        MultiAgentRunner(world, missing, None, "cpu")


def test_mappo_through_skrl_has_a_centralised_critic(tmp_path):
    import skrl
    from skrl.trainers.torch import SequentialTrainer

    from agile.marl.skrl import SkrlMultiAgentView, mappo

    skrl.logger.setLevel("WARNING")  # its INFO lines at close would hit pytest's closed capture stream

    world = two_t1_world()
    view = SkrlMultiAgentView(world)
    env, learner = mappo(view, rollouts=4, mini_batches=2, experiment_dir=str(tmp_path))
    SequentialTrainer(env=env, agents=learner, cfg={"timesteps": 8, "headless": True,
                                                     "disable_progressbar": True}).train()

    def input_size(model):
        return next(m for m in model.modules() if isinstance(m, torch.nn.Linear)).in_features

    critic_dim = world.agents["t1_a"].observation_manager.group_dims["critic"]
    assert input_size(learner.models["t1_a"]["value"]) == 2 * critic_dim  # both robots' critic groups
    assert input_size(learner.models["t1_a"]["policy"]) == world.agents["t1_a"].observation_manager.group_dims[
        "policy"]
    assert len(learner.tracking_data["Loss / Value loss (t1_b)"]) == 2  # two updates of 4 steps
    with pytest.raises(ConfigError, match="different steps"):
        SkrlMultiAgentView(gym.make(TASK, num_envs=1, device="cpu").unwrapped)


def test_commands_train_eval_play_and_export_a_multi_agent_task(tmp_path, capsys):
    import importlib
    import json
    from pathlib import Path

    def run(command, *args):
        """(exit code, stdout, stderr) of `agile <command> ... --task TASK --device cpu`, in this process."""
        code = 0
        try:
            code = importlib.import_module(f"agile.run.{command}").main([*args, "--task", TASK, "--device", "cpu"])
        except SystemExit as exit_info:
            code = exit_info.code
        out, err = capsys.readouterr()
        return code or 0, out, err

    shipped = Path(__file__).resolve().parents[1] / "agile" / "data" / "policy"
    code, out, err = run("train", "--num_envs", "2", "--max_iterations", "1", "--log_root", str(tmp_path),
                         "--init_policy", f"g1={shipped / 'Velocity-G1-History-v0.pt'}",
                         "--init_policy", f"t1={shipped / 'Velocity-T1-v0.pt'}", "agent.rollout_s=0.08")
    assert code == 0, out + err
    run_dir = next((tmp_path / "multi_rate_g1_t1_velocity").iterdir())
    for group in ("g1", "t1"):
        assert (run_dir / group / "model_0.pt").is_file() and (run_dir / "exported" / group / "policy.onnx").is_file()
    assert f"exported policy in {run_dir / 'exported'}/<group>" in out, out  # where the files are
    assert "Learning iteration 0/1" in out and "\x1b[" not in out  # each group's block, no escape codes in a file
    code, out, err = run("eval", "--checkpoint", str(run_dir), "--num_envs", "2", "--episode_length_s", "0.4",
                         "--out", str(tmp_path / "eval.json"))
    assert code == 0, out + err
    metrics = json.loads((tmp_path / "eval.json").read_text())["agents"]
    assert set(metrics) == {"g1", "t1"} and metrics["t1"]["control_hz"] == 25.0 and metrics["g1"]["episodes"] == 2
    code, out, err = run("play", "--checkpoint", str(run_dir), "--num_envs", "1", "--num_steps", "4")
    assert code == 0 and "t1 at 25 Hz" in out, out + err
    code, out, err = run("export", "--checkpoint", str(run_dir), "--out", str(tmp_path / "exported"))
    assert code == 0 and (tmp_path / "exported" / "t1" / "io_descriptor.yaml").is_file(), out + err
    code, out, err = run("train", "--init_policy", f"robot={shipped / 'Velocity-T1-v0.pt'}")
    assert code == 2 and err.startswith("error: --init_policy takes GROUP=PATH with GROUP one of ['g1', 't1']"), err
    # each group's checkpoint records the training's wall time, and a resume counts on from it, group by group
    import torch

    g1_checkpoint = torch.load(run_dir / "g1" / "model_0.pt", weights_only=True)
    assert 0 < g1_checkpoint["infos"]["wall_s"] < 600
    g1_checkpoint["infos"]["wall_s"] = 1e6
    torch.save(g1_checkpoint, run_dir / "g1" / "model_0.pt")
    code, out, err = run("train", "--num_envs", "2", "--max_iterations", "1", "--log_root", str(tmp_path / "resumed"),
                         "--resume", "--checkpoint", str(run_dir), "agent.rollout_s=0.08")
    assert code == 0, out + err
    resumed_dir = next((tmp_path / "resumed" / "multi_rate_g1_t1_velocity").iterdir())
    wall_s = {group: torch.load(resumed_dir / group / "model_1.pt", weights_only=True)["infos"]["wall_s"]
              for group in ("g1", "t1")}
    assert 1e6 < wall_s["g1"] < 1e6 + 600 and 0 < wall_s["t1"] < 1200, wall_s


ROBOTS = ("go1_a", "go1_b")


def test_each_go1_sees_the_other_in_its_own_heading_frame():
    """Shared-Go1: go1_a at the origin heading +x, go1_b 1 m ahead and 2 m to its left heading +y, walking +x at
    0.5 m/s. a sees b at (1, 2), moving (0.5, 0); b sees a behind and to its left, (-2, 1), moving (0, 0.5) in b's
    frame; a b 5 m ahead is seen at the 3 m clip. The keep-clear penalty counts from 0.8 m between the roots: nothing
    at 2.2 m or 5 m, half at 0.4 m, for both."""
    from agile.tasks.multi_agent.velocity_agents import closeness_to_other_robot, other_robot_in_heading_frame

    world = gym.make("Shared-Go1-Velocity-v0", num_envs=1, device="cpu", seed=0).unwrapped
    try:
        world.reset()
        go1_a, go1_b = world.scene["go1_a"], world.scene["go1_b"]
        height_m = float(go1_a.root_pose_w[0, 2])

        def place(robot, x_m: float, y_m: float, quat_xyzw: list[float], vx_mps: float = 0.0) -> None:
            pose = torch.tensor([[x_m, y_m, height_m, *quat_xyzw]])
            pose[:, :2] += world.env_origins[:, :2]
            velocity = torch.tensor([[vx_mps, 0.0, 0.0, 0.0, 0.0, 0.0]])
            robot.write_root_state(pose, velocity, torch.tensor([True]))

        half = 0.5 ** 0.5
        place(go1_a, 0.0, 0.0, [0.0, 0.0, 0.0, 1.0])
        place(go1_b, 1.0, 2.0, [0.0, 0.0, half, half], vx_mps=0.5)
        world.sim.forward()
        world.scene.update()
        seen_by_a = other_robot_in_heading_frame(world.agents["go1_a"], max_distance_m=3.0)
        seen_by_b = other_robot_in_heading_frame(world.agents["go1_b"], max_distance_m=3.0)
        torch.testing.assert_close(seen_by_a[0], torch.tensor([1.0, 2.0, 0.5, 0.0]), atol=1e-3, rtol=0)
        torch.testing.assert_close(seen_by_b[0], torch.tensor([-2.0, 1.0, 0.0, 0.5]), atol=1e-3, rtol=0)

        def closeness() -> list[float]:
            return [float(closeness_to_other_robot(world.agents[name], clearance_m=0.8)[0]) for name in ROBOTS]

        assert closeness() == [0.0, 0.0]
        place(go1_b, 5.0, 0.0, [0.0, 0.0, 0.0, 1.0])
        world.sim.forward()
        world.scene.update()
        seen_by_a = other_robot_in_heading_frame(world.agents["go1_a"], max_distance_m=3.0)
        torch.testing.assert_close(seen_by_a[0, :2], torch.tensor([3.0, 0.0]), atol=1e-3, rtol=0)
        assert closeness() == [0.0, 0.0]
        place(go1_b, 0.0, 0.4, [0.0, 0.0, 0.0, 1.0])
        world.sim.forward()
        world.scene.update()
        assert closeness() == pytest.approx([0.5, 0.5], abs=1e-3)
        assert world.agents["go1_a"].reward_manager.get_term_cfg("keep_clear").weight < 0
        term_dims = world.agents["go1_a"].observation_manager.term_dims
        assert term_dims["policy"]["other_robot"] == 4 * 5 and term_dims["critic"]["other_robot"] == 4  # 5-step history
    finally:
        world.close()


def test_multi_agent_evaluation_names_the_term_that_ended_each_fall():
    """Shared-Go1 with go1_a's tilt limit at 0 rad: go1_a falls at once by bad_orientation, and go1_b's falls are
    counted apart (soft death: each agent's own terms). The evaluation reports the falls by term, as the
    single-agent one does."""
    import dataclasses
    import math

    from agile.run.multi_agent_world import evaluate, evaluation_cfg

    env_cfg, _ = agile.tasks.load_cfgs("Shared-Go1-Velocity-v0")
    env_cfg.agents["go1_a"].terminations = dataclasses.replace(
        env_cfg.agents["go1_a"].terminations, bad_orientation=dataclasses.replace(
            env_cfg.agents["go1_a"].terminations.bad_orientation, params={"limit_angle_rad": 0.0}))
    env_cfg.num_envs = 2
    world = gym.make("Shared-Go1-Velocity-v0", cfg=evaluation_cfg(env_cfg, pushes=False), device="cpu").unwrapped
    try:
        view = GroupVecEnv(world, "go1", AgentGroupCfg(agents=list(ROBOTS), mode="shared"))
        standing = {view: lambda obs: torch.zeros(obs["policy"].shape[0], view.num_actions)}
        metrics = evaluate(world, standing, num_slots=3)
    finally:
        world.close()
    a, b = metrics["go1_a"], metrics["go1_b"]
    # go1_a falls at the first step in both envs and stays down while go1_b plays on: one fall per env
    assert a["falls"] == 2 and a["falls_by_term"]["bad_orientation"] == 2
    assert "time_out" not in a["falls_by_term"] and set(a["falls_by_term"]) == set(b["falls_by_term"])
    assert b["falls"] == 0 and not any(b["falls_by_term"].values())
    assert math.isfinite(a["lin_vel_error_mps"])


def test_a_go1_whose_trunk_touches_the_other_plays_on_and_one_on_its_back_falls():
    """Shared-Go1's trunk-contact termination reads the ground's force alone: in env 0 go1_b's trunk pushes on go1_a's
    (thousands of N) and neither falls by trunk contact; in env 1 go1_a lies on its back, trunk on the ground, and
    falls by it."""
    world = gym.make("Shared-Go1-Velocity-v0", num_envs=2, device="cpu", seed=0).unwrapped
    try:
        world.reset()
        go1_a, go1_b = world.scene["go1_a"], world.scene["go1_b"]
        height_m = float(go1_a.root_pose_w[0, 2])
        upright, on_its_back = [0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0]

        def place(robot, x_m: list[float], z_m: list[float], quat_xyzw: list[list[float]]) -> None:
            pose = robot.root_pose_w.clone()
            pose[:, :2] = world.env_origins[:, :2]
            pose[:, 0] += torch.tensor(x_m)
            pose[:, 2] = torch.tensor(z_m)
            pose[:, 3:7] = torch.tensor(quat_xyzw)
            robot.write_root_state(pose, torch.zeros_like(robot.root_com_vel_w), torch.tensor([True, True]))

        place(go1_a, [0.0, 0.0], [height_m, 0.04], [upright, on_its_back])
        place(go1_b, [0.36, 3.0], [height_m, height_m], [upright, upright])  # trunks 0.38 m long: they overlap
        world.sim.forward()
        world.scene.update()
        world.step({name: torch.zeros(2, world.agents[name].action_manager.total_action_dim)
                    for name in world.acting_agents})
        touching_n = world.scene["go1_a_touches_go1_b"].force_matrix_w.norm(dim=-1).sum(dim=(1, 2))
        assert touching_n[0] > 1000.0 and touching_n[1] == 0.0
        trunk_net_n = world.scene["go1_a_contact_forces"].net_forces_w_history.norm(dim=-1).amax(dim=1)[:, 0]
        assert trunk_net_n[0] > 20.0  # the net force would have ended the episode
        trunk_contact = {name: world.agents[name].termination_manager.term_dones["illegal_ground_contact"].tolist()
                         for name in ROBOTS}
        assert trunk_contact == {"go1_a": [False, True], "go1_b": [False, False]}
    finally:
        world.close()


def test_both_multi_agent_velocity_tasks_end_on_the_grounds_force_on_a_trunk_alone():
    """MultiRate-G1-T1's humanoids, as Shared-Go1's quadrupeds: each agent's trunk-contact termination reads its
    robot's sensor filtered to the ground, on the same trunk bodies as its single-robot task's termination."""
    import agile.tasks

    for task in ("MultiRate-G1-T1-Velocity-v0", "Shared-Go1-Velocity-v0"):
        env_cfg, _ = agile.tasks.load_cfgs(task)
        for name, agent in env_cfg.agents.items():
            term = agent.terminations.illegal_ground_contact
            sensor = env_cfg.scene.contact_sensors[agent.scene_names[TRUNK_ON_GROUND]]
            assert term.params["sensor_cfg"].name == TRUNK_ON_GROUND, (task, name)
            assert sensor.entity == name and sensor.filter_entity == "ground", (task, name)
            assert list(sensor.body_names) == list(term.params["sensor_cfg"].body_names), (task, name)
