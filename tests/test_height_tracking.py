"""HeightTracking-G1-v0 built on CPU (3 envs, 2 terrain rows): its fallen-state dataset made when built (a tiny one),
steps, resets and one PPO iteration; the command-following lift's force for a known height error and vertical velocity, push-down on and off, the weight-fraction limit."""

from __future__ import annotations

import types
from pathlib import Path

import pytest
import torch

from agile.errors import AgileError


TASK = "HeightTracking-G1-v0"
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def env_and_agent(height_tracking_env_and_agent):
    return height_tracking_env_and_agent


def test_the_built_env_reset_and_one_ppo_iteration(env_and_agent, tmp_path):
    from rsl_rl.runners import OnPolicyRunner

    from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict

    env, agent_cfg = env_and_agent
    assert len(env.event_manager.get_term("reset_base").states) > 0  # the dataset was collected and handed over
    obs = env.reset()[0]
    assert obs["policy"]["height_command"].shape == (3, 5) and obs["critic"]["height_command"].shape == (3, 5)
    for _ in range(3):
        env.step(torch.zeros(3, env.action_manager.total_action_dim))
    agent_cfg.num_steps_per_env = 4
    agent_cfg.algorithm.num_mini_batches = 2
    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=str(tmp_path), device="cpu")
    runner.learn(num_learning_iterations=1)
    assert (tmp_path / "model_0.pt").is_file()
    assert not {name: int(n) for name, n in env.reward_manager.nonfinite_count.items() if int(n)}


def test_fallen_states_are_collected_without_the_lift(env_and_agent):
    # the lift follows the height command; left on while the robots fall, it held them up towards the command the
    # build left (0.92 m): pelvises 0.5-0.7 m up, most still swinging and dropped. Off, they lie (pelvis ~0.1 m).
    env, _ = env_and_agent
    assert env.action_manager.training_only_terms == ["lift"]  # what the collection switches off
    states = env.event_manager.get_term("reset_base").states
    pelvis_m = states.tensors["root_pos_env_m"][:, 2]  # above the cell's origin, on the terrain
    assert len(states) >= 4 and (pelvis_m < 0.35).all(), pelvis_m
    assert env.action_manager.get_term("lift").scale.item() == 1.0  # put back after the collection


def test_eval_reports_the_height_error_by_commanded_height(env_and_agent):
    from agile.run.rollout_metrics import evaluate

    env, _ = env_and_agent
    num_actions = env.action_manager.total_action_dim
    torch.manual_seed(1)
    full_length = env.max_episode_length
    env.max_episode_length = 150  # 3 s episodes, 1 s of each past the 2 s settle time: enough for the bins
    try:
        metrics = evaluate(env, lambda obs: torch.zeros(env.num_envs, num_actions), num_episodes=1)
    finally:
        env.max_episode_length = full_length
    rows = metrics["error_by_command"]["height_error_m_by_height_m"]
    assert rows and all(row["error"] >= 0.0 and row["steps"] > 0 for row in rows)
    # by the terrain cell each episode spawned on: every ended episode counted once, under its row and sub-terrain
    cells = metrics["episodes_by_variant"]["terrain_cell"]
    assert sum(row["episodes"] for row in cells) == metrics["episodes"]
    type_names = env.sim.terrain.type_names
    assert all(row["variant"].startswith("row ") and " col " in row["variant"]
               and row["variant"].split(" ", 4)[4] in type_names for row in cells)
    # and by when in the episode they ended (3 s episodes here: every time-out in the last second)
    by_time = metrics["falls_by_episode_time_s"]
    assert sum(row["ended"] for row in by_time) == metrics["episodes"]
    assert sum(row["falls"] for row in by_time) == metrics["falls"]
    assert all(0.0 <= row["time_s"][0] < row["time_s"][1] <= 3.0 + 1e-6 for row in by_time)
    # and by robot: no more robots fell than falls, each counted once
    assert metrics["robots_fallen"] <= min(metrics["falls"], env.num_envs)
    assert metrics["robot_fall_rate"] == pytest.approx(metrics["robots_fallen"] / env.num_envs)
    assert (metrics["max_falls_of_one_robot"] > 0) == (metrics["falls"] > 0)
    assert {tuple(row["command"]) for row in rows} <= {(0.0, 0.2), (0.2, 0.4), (0.4, 0.6), (0.6, 0.8), (0.8, 0.9),
                                                         (0.9, None)}
    # the same steps as the episode metric: their mean over the steps is the metric's mean over the episodes' steps
    steps = sum(row["steps"] for row in rows)
    mean = sum(row["error"] * row["steps"] for row in rows) / steps
    assert 0.0 <= mean < 2.0
    env.reset()


def test_sweep_command_holds_one_height_per_env_and_reports_where_each_settles(env_and_agent, capsys):
    from agile.run.command_sweep import command_sweep, reward_terms_table, swept_command, sweep_table

    env, _ = env_and_agent
    term = env.command_manager.get_term("height")
    num_actions = env.action_manager.total_action_dim
    full_length = env.max_episode_length
    env.max_episode_length = 100  # 2 s episodes, the reached height counted from 1 s
    # the reward terms summed apart, from inside the policy: it sees each step's rewards before the next step (the
    # last step's, a time-out, count nothing: the env has reset and its episode time is 0)
    reward_sums = {name: torch.zeros(env.num_envs) for name in env.reward_manager.weights}
    robot = env.scene["robot"]
    joint_pos_sums = torch.zeros_like(robot.joint_pos)
    late_steps = torch.zeros(env.num_envs)

    def policy(obs):
        late = (env.episode_length_buf * env.step_dt >= 1.0).float()
        for name, reward in env.reward_manager.step_reward.items():
            reward_sums[name] += reward * late
        joint_pos_sums.add_(robot.joint_pos * late.unsqueeze(1))
        late_steps.add_(late)
        return torch.zeros(env.num_envs, num_actions)

    try:
        rows = command_sweep(env, policy, 1, [0.3, 0.8, 0.5], settled_after_s=1.0)
        held = term.command[:, 0].tolist()
    finally:
        env.max_episode_length = full_length
        term.set_fixed_command(None)
    assert held == pytest.approx([0.3, 0.8, 0.5])  # env i holds value i mod 3, whatever the timers drew
    assert [row["command"] for row in rows] == [0.3, 0.8, 0.5] and all(row["num_envs"] == 1 for row in rows)
    for row in rows:
        (reached,) = row["reached_height_m_per_env"]
        assert row["mean_signed_error_height_m"] == pytest.approx(reached - row["command"], abs=1e-3)
        assert row["mean_abs_error_height_m"] == pytest.approx(abs(reached - row["command"]), abs=1e-3)
        assert row["reached_height_m_p10_p50_p90"] == pytest.approx([reached] * 3, abs=1e-3)
        assert row["episodes"] >= 1 and 0.0 <= row["fall_rate"] <= 1.0
    for env_id, row in enumerate(rows):  # env i holds value i: its own reward balance
        balance = row["reward_per_step"]
        assert set(balance) == {"total", *env.reward_manager.weights}
        for name, sums in reward_sums.items():
            assert balance[name] == pytest.approx(float(sums[env_id] / late_steps[env_id]), rel=1e-3, abs=1e-4), name
        assert balance["total"] == pytest.approx(sum(v for k, v in balance.items() if k != "total"), abs=1e-3)
        assert 0.0 < balance["base_height_fine"] <= env.reward_manager.weights["base_height_fine"]  # exp kernel x weight
        posture = row["joint_pos_rad"]
        assert list(posture) == robot.joint_names
        expected = joint_pos_sums[env_id] / late_steps[env_id]
        assert list(posture.values()) == pytest.approx(expected.tolist(), abs=2e-3)
    table = sweep_table(rows)
    assert table.count("\n") == 1 + len(rows) and "0.800" in table
    balance_table = reward_terms_table(rows, num_terms=3)
    assert balance_table.count("\n") == 1 + len(rows) and balance_table.splitlines()[0].count("|") == 6
    # refused: more values than envs, an episode no longer than the settle time, a task without such a command
    for values, settled_after_s in (([0.1, 0.2, 0.3, 0.4], 1.0), ([0.3], 30.0)):
        with pytest.raises(AgileError):
            command_sweep(env, lambda obs: torch.zeros(env.num_envs, num_actions), 1, values, settled_after_s)
    velocity_only = types.SimpleNamespace(command_manager=types.SimpleNamespace(terms={}, active_terms=["velocity"]))
    with pytest.raises(AgileError) as refused:
        swept_command(velocity_only)
    assert "--sweep_command" in str(refused.value) and "(commands: ['velocity'])" in str(refused.value)
    env.reset()


def test_the_joint_deviation_gate_on_the_command(env_and_agent):
    """AGILE's gate (the root above min_height_m) alone by default; with min_command_m, also only while the command
    asks for at least that height (the trained policy avoided every posture between about 0.65 and 0.85 m that the
    root gate charges the whole deviation: docs/height_tracking.md)."""
    from agile.tasks.height_tracking import mdp
    from agile.rl_env.managers import SceneEntityCfg

    env, _ = env_and_agent
    registered = env.reward_manager.get_term_cfg("joint_deviation_l1")
    assert registered.params["min_command_m"] is None and registered.params["min_height_m"] == 0.5
    term = env.command_manager.get_term("height")
    joints = SceneEntityCfg("robot")
    joints.resolve(env)
    try:
        term.set_fixed_command(torch.tensor([[0.3], [0.95], [0.9]]))
        generator = torch.Generator().manual_seed(0)
        with torch.inference_mode():
            for _ in range(3):  # off the default pose, in every env
                env.step(torch.randn(env.num_envs, env.action_manager.total_action_dim, generator=generator))
        ungated = mdp.joint_deviation_if_standing(env, -1.0, joints)  # every root "above" -1 m
        assert (ungated > 0).all()
        agile_gate = mdp.joint_deviation_if_standing_asked(env, -1.0, joints, "height")
        asked = mdp.joint_deviation_if_standing_asked(env, -1.0, joints, "height", min_command_m=0.9)
    finally:
        term.set_fixed_command(None)
        env.reset()
    assert torch.equal(agile_gate, ungated)
    assert asked[0] == 0.0 and torch.equal(asked[1:], ungated[1:])


def _lift_force_n(env, target_m: list[float], vel_z_mps: float) -> tuple[torch.Tensor, torch.Tensor]:
    """The lift's vertical force on the torso for the given commands, the robot at its default pose moving up at
    vel_z_mps; and the tracked point's measured height."""
    robot, lift = env.scene["robot"], env.action_manager.get_term("lift")
    command = env.command_manager.get_term("height")
    everyone = torch.ones(env.num_envs, dtype=torch.bool)
    velocity = torch.zeros(env.num_envs, 6)
    velocity[:, 2] = vel_z_mps
    robot.write_root_state(robot.root_pose_w.clone(), velocity, everyone)
    env.sim.forward()
    env.scene.update()
    command.target_height_m[:] = torch.tensor(target_m)
    torso = robot.find_bodies("torso_link")[0][0]
    robot.body_wrench_w[:, torso] = 0.0
    lift.apply_actions()
    lift.apply_wrench()
    return robot.body_wrench_w[:, torso, 2].clone(), command.measured_height_m.clone()


def test_command_following_lift(env_and_agent):
    env, _ = env_and_agent
    reset_params = env.event_manager.term_cfgs["reset_base"].params
    standing_ratio = reset_params["standing_ratio"]
    reset_params["standing_ratio"] = 1.0  # every robot at its default pose, its tracked point about 1.0 m up
    env.reset()
    robot, lift = env.scene["robot"], env.action_manager.get_term("lift")
    lift.scale_forces(1.0)
    # the masses as built (before the startup randomisation), as AGILE's default_mass
    weight_n = robot.default_body_mass.sum(dim=1).mean().item() * 9.81
    assert lift.force_limit_n == pytest.approx(0.9 * weight_n, rel=1e-5)  # G1 about 33 kg: about 290 N
    # small errors stay below the limit: F = 5000·(target - h) - 2500·v_z
    force, height = _lift_force_n(env, [0.0, 0.0, 0.0], 0.0)
    targets = (height + torch.tensor([0.02, -0.02, 0.01])).tolist()
    force, height = _lift_force_n(env, targets, 0.01)
    expected = 5000.0 * (torch.tensor(targets) - height) - 2500.0 * 0.01
    assert torch.allclose(force, expected, atol=0.5), (force, expected)
    # far below / far above the target: clamped to ±0.9 of the weight (push-down allowed)
    force, height = _lift_force_n(env, [1.5, 0.05, 1.5], 0.0)
    assert force.tolist() == pytest.approx([0.9 * weight_n, -0.9 * weight_n, 0.9 * weight_n], rel=1e-4)
    # a negative command (lie relaxed): no force at all
    force, _ = _lift_force_n(env, [-0.3, -0.3, -0.3], 0.0)
    assert not force.any()
    # without push-down, the force is clamped at 0 from below
    lift.kernel_inputs[14] = 0  # allow_push_down, as LiftAction built it from its config
    force, _ = _lift_force_n(env, [0.05, 0.05, 0.05], 0.0)
    assert lift.cfg.allow_push_down and not force.any()
    lift.kernel_inputs[14] = 1
    # the curriculum's scale scales the gains and the limit
    lift.scale_forces(0.5)
    force, height = _lift_force_n(env, [0.05, 0.05, 0.05], 0.0)
    assert force.tolist() == pytest.approx([-0.45 * weight_n] * 3, rel=1e-4)
    lift.scale_forces(1.0)
    reset_params["standing_ratio"] = standing_ratio
    env.reset()


def _zero_action_steps(env, num_steps: int, measure) -> torch.Tensor:
    """(num_steps, ...) `measure()` after each of `num_steps` env steps with a zero action."""
    values = []
    for _ in range(num_steps):
        env.step(torch.zeros(env.num_envs, env.action_manager.total_action_dim))
        values.append(measure())
    return torch.stack(values)


def _restore_after(env, standing_ratio: float, lift_scale: float, seed: int = 0):
    """Reset the env with this standing share and lift strength (the curriculum's, which every reset hands to the
    lift); the caller puts the defaults back with a second call."""
    env.event_manager.term_cfgs["reset_base"].params["standing_ratio"] = standing_ratio
    env.curriculum_manager.funcs["adaptive_lift"].scale.fill_(lift_scale)
    # the same states whichever tests ran before in this worker (the draws use the global generator)
    torch.manual_seed(seed)
    env.reset()


def test_the_lifts_yaw_damping_does_not_spin_an_upright_g1(env_and_agent):
    # AGILE's 100 N·m·s/rad, applied explicitly at 5 ms on the root, spun an upright G1 at rest at 5.4 rad/s for
    # as long as the lift is at full strength (the start of training)
    env, _ = env_and_agent
    robot = env.scene["robot"]
    with torch.inference_mode():
        try:
            _restore_after(env, standing_ratio=1.0, lift_scale=1.0)
            yaw_rates = _zero_action_steps(env, 25, lambda: robot.root_ang_vel_w[:, 2].abs())[5:]
            assert yaw_rates.mean().item() < 0.5, yaw_rates.mean(dim=0)
        finally:
            _restore_after(env, standing_ratio=0.5, lift_scale=1.0)


def test_illegal_contacts_cost_a_lying_g1_once_not_per_wrist_link(env_and_agent):
    # AGILE's illegal_contact: whether any wrist link touches (-2), not how many (a lying G1: -4 with two links down)
    env, _ = env_and_agent
    with torch.inference_mode():
        try:
            costs = []
            for seed in range(6):  # lying states of this small dataset, drawn until some have a wrist on the ground
                _restore_after(env, standing_ratio=0.0, lift_scale=0.0, seed=seed)
                costs.append(_zero_action_steps(
                    env, 10, lambda: env.reward_manager.step_reward["illegal_contacts"].clone()))
            costs = torch.cat(costs)
            assert set(costs.unique().tolist()) <= {0.0, -2.0} and (costs == -2.0).any(), costs.unique()
        finally:
            _restore_after(env, standing_ratio=0.5, lift_scale=1.0)


def test_tracked_point_standing_crouched_and_lying(env_and_agent):
    # AGILE's tracked point: 0.2 m above the torso origin along the torso's z, the torso origin 0.044 m above the
    # pelvis (Unitree's waist joints, in AGILE's model as in Menagerie's). Standing in the default pose it reads
    # about 1.00 m, not the 0.92 m top of the range ("stand", AGILE's 0.72 m pelvis + 0.2 m): 0.06-0.1 m above it,
    # within the 0.1 m the terrain curriculum and the lift's decay count as tracked. The top itself is an upright
    # crouch (hips -0.6, knees 1.2, ankles -0.6 rad: pelvis about 0.68 m); lying reads about 0.1 m.
    env, _ = env_and_agent
    robot, command = env.scene["robot"], env.command_manager.get_term("height")
    top_m = command.cfg.ranges.height_m[1]
    pelvis = robot.find_bodies("pelvis")[0][0]
    feet = robot.find_bodies(["left_ankle_roll_link", "right_ankle_roll_link"])[0]
    everyone = torch.ones(env.num_envs, dtype=torch.bool)
    with torch.inference_mode():
        try:
            _restore_after(env, standing_ratio=1.0, lift_scale=0.0)
            above_pelvis_m = command.tracked_point_pos_w()[:, 2] - robot.body_pose_w[:, pelvis, 2]
            assert above_pelvis_m.tolist() == pytest.approx([0.244] * env.num_envs, abs=0.002)
            above_top_m = command.measured_height_m - top_m
            assert ((above_top_m > 0.05) & (above_top_m < 0.1)).all(), above_top_m
            # the crouch, its feet put back down where the standing feet were
            feet_z_m = robot.body_pose_w[:, feet, 2].mean(dim=1)
            crouch = robot.default_joint_pos.clone()
            for joints, angle_rad in ((".*_hip_pitch_joint", -0.6), (".*_knee_joint", 1.2),
                                      (".*_ankle_pitch_joint", -0.6)):
                crouch[:, robot.find_joints(joints)[0]] = angle_rad
            robot.write_joint_state(crouch, torch.zeros_like(crouch), everyone)
            env.sim.forward()
            env.scene.update()
            feet_rise_m = robot.body_pose_w[:, feet, 2].mean(dim=1) - feet_z_m
            crouched_m = command.measured_height_m - feet_rise_m
            assert crouched_m.tolist() == pytest.approx([top_m] * env.num_envs, abs=0.02)
            _restore_after(env, standing_ratio=0.0, lift_scale=0.0)
            env.step(torch.zeros(env.num_envs, env.action_manager.total_action_dim))
            assert (command.measured_height_m < 0.25).all(), command.measured_height_m
        finally:
            _restore_after(env, standing_ratio=0.5, lift_scale=1.0)


def test_the_exported_policy_runs_a_height_ramp_in_plain_mujoco(env_and_agent, tmp_path):
    """The IO descriptor names the tracked point, and sim2mujoco drives the policy with a height ramp there."""
    from rsl_rl.runners import OnPolicyRunner

    from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict
    from agile.run import sim2mujoco
    from agile.run.export import export
    from agile.deploy.mujoco_policy import DescriptorPolicy, yaml_load

    env, agent_cfg = env_and_agent
    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=None, device="cpu")
    files = export(TASK, env, agent_cfg, runner, str(tmp_path))
    descriptor = yaml_load(files["io_descriptor"])
    params = descriptor["commands"]["height"]["params"]
    assert params["body_name"] == "torso_link" and params["offset_b_m"] == [0.0, 0.0, 0.2]
    metrics = sim2mujoco.run(descriptor, sim2mujoco.default_mjcf(descriptor),
                             lambda robot: DescriptorPolicy(descriptor, robot, files["jit"]), episodes=1,
                             duration_s=1.5, height_ramp=(0.92, 0.0))
    assert metrics["falls"] == 0 and metrics["mean_episode_length_s"] == pytest.approx(1.5)  # lying is no fall
    assert 0.0 < metrics["final_height_m"] < 1.3 and metrics["height_error_m"] >= 0.0


def test_a_height_ramp_goes_down_and_back_up_then_holds():
    import numpy as np

    from agile.run.mujoco_commands import HeightCommands, make_commands

    spec = {"type": "SmoothHeightCommand", "ranges": {"height_m": [-0.5, 0.92]},
            "params": {"body_name": "torso_link", "offset_b_m": [0.0, 0.0, 0.2], "settle_time_s": 2.0,
                       "standing_ratio": 0.3, "flat_ratio": 0.2, "resampling_time_range_s": [1.0, 7.0]}}
    ramp = make_commands(spec, np.random.default_rng(0), 0.02, height_ramp=(0.92, -0.5))
    ramp.start_episode(650)  # 13 s: 12 s down and up, 1 s held
    heights = np.array([ramp.command(step)[0] for step in range(650)])
    assert heights[0] == pytest.approx(0.92) and heights.min() == pytest.approx(-0.5, abs=1e-3)
    assert heights.argmin() == pytest.approx(300, abs=1) and np.all(heights[600:] == pytest.approx(0.92))
    drawn = HeightCommands(spec, np.random.default_rng(0), 0.02)
    drawn.start_episode(50 * 600)
    targets = np.array([drawn.command(step)[0] for step in range(0, 50 * 600, 50)])
    assert 0.2 < np.mean(targets == 0.92) < 0.5 and 0.1 < np.mean(targets == -0.5) < 0.35  # the training shares
    with pytest.raises(ValueError, match="one height"):
        make_commands(spec, np.random.default_rng(0), 0.02, fixed=[0.5, 0.0, 0.0])
    with pytest.raises(ValueError, match="--height_ramp is for a height command"):
        make_commands({"type": "UniformVelocityCommand", "ranges": {}}, np.random.default_rng(0), 0.02,
                      height_ramp=(0.9, 0.0))
