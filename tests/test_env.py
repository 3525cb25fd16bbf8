"""ManagerBasedRLEnv on real physics (CPU, a few envs)."""

import gymnasium as gym
import newton
import newton.examples
import pytest
import torch
import warp as wp
from tensordict import TensorDict
from commands import FLAT_GROUND
from scenes import robot_sim

import agile.tasks
from agile.sim import ArticulationCfg
from agile.utils.config import ConfigError


def test_gym_make_from_user_code_with_overrides():
    env = gym.make("Velocity-G1-History-v0", num_envs=2, device="cpu",
                   overrides=["episode_length_s=5.0", "rewards.track_lin_vel_xy_exp.weight=1.5", *FLAT_GROUND])
    u = env.unwrapped
    assert u.max_episode_length == 250 and u.reward_manager.weights["track_lin_vel_xy_exp"].item() == 1.5
    obs, extras = env.reset()
    assert isinstance(obs, TensorDict) and set(obs.keys()) == {"policy", "critic"}
    # policy: 5-step history of ang vel (3), gravity (3), command (3), 14 joint pos, 14 joint vel, 14 actions
    assert sum(v.shape[-1] for v in obs["policy"].values()) == 5 * (3 + 3 + 3 + 14 + 14 + 14)
    assert u.action_space.shape == (2, 14)
    obs, reward, terminated, truncated, extras = env.step(torch.zeros(2, 14))
    assert reward.shape == (2,) and terminated.dtype == torch.bool and "time_outs" in extras
    assert "Episode_Reward/track_lin_vel_xy_exp" in extras["log"]


def test_unknown_task_lists_registered_ids():
    with pytest.raises(KeyError, match="Velocity-T1-v0"):
        agile.tasks.load_cfgs("Velocity-T2-v0")


def test_regex_matching_no_joint_is_a_config_error_naming_the_term():
    with pytest.raises(ConfigError, match=r"action term 'joint_pos'.*'Hip_X' matches no joint.*Left_Hip_Pitch"):
        gym.make("Velocity-T1-v0", num_envs=1, device="cpu",
                 overrides=["actions.joint_pos.joint_names=['Hip_X']", *FLAT_GROUND])


def test_views_are_zero_copy(t1_env):
    robot = t1_env.scene["robot"]
    assert robot.joint_pos.data_ptr() == wp.to_torch(t1_env.sim.state.joint_q).data_ptr() + 7 * 4
    robot.joint_pos[0, 0] = 0.123
    assert t1_env.sim.state.joint_q.numpy()[7] == pytest.approx(0.123)


def test_time_out_resets_only_the_finished_env(t1_env):
    env = t1_env
    env.reset()
    n = env.num_envs
    action = torch.zeros(n, env.action_manager.total_action_dim)
    env.step(action)
    env.episode_length_buf[1] = env.max_episode_length - 1
    _, _, terminated, truncated, extras = env.step(action)
    assert truncated[1] and not terminated[1]
    assert env.episode_length_buf[1] == 0
    assert (env.episode_length_buf[[0, 2]] == 2).all() | terminated[[0, 2]].any()
    assert extras["log"]["Episode_Termination/time_out"] == pytest.approx(1.0)


def test_nan_world_is_reset_counted_and_training_goes_on(t1_env):
    env = t1_env
    env.reset()
    action = torch.zeros(env.num_envs, env.action_manager.total_action_dim)
    env.step(action)
    env.scene["robot"].joint_vel[0, 3] = float("nan")
    obs, reward, terminated, truncated, extras = env.step(action)
    assert terminated[0] and env.episode_length_buf[0] == 0
    assert torch.isfinite(reward).all()
    assert all(torch.isfinite(v).all() for v in obs["policy"].values())
    assert extras["log"]["Episode_Termination/sim_unstable"] > 0
    for _ in range(3):
        obs, reward, *_ = env.step(action)
    assert torch.isfinite(env.scene["robot"].joint_pos).all() and torch.isfinite(reward).all()


def test_reset_events_randomise_within_ranges(t1_env):
    env = t1_env
    env.reset()
    robot = env.scene["robot"]
    offset = robot.root_pos_w[:, :2] - env.env_origins[:, :2]
    assert (offset.abs() <= 2.5 + 1e-4).all()
    ratio = robot.joint_pos / torch.where(robot.default_joint_pos == 0, 1.0, robot.default_joint_pos)
    nonzero = robot.default_joint_pos != 0
    assert ((ratio[nonzero] >= 0.8 - 1e-4) & (ratio[nonzero] <= 1.2 + 1e-4)).all()


@pytest.mark.parametrize("asset", ["nv_humanoid.xml", "quadruped.urdf"])
def test_user_robot_files_load(asset):
    cfg = ArticulationCfg(model_file=str(newton.examples.get_asset(asset)), init_pos_m=(0.0, 0.0, 1.5))
    sim = robot_sim(cfg, num_envs=2)
    z0 = sim.scene["robot"].root_pos_w[:, 2].clone()
    sim.step(4)
    assert sim.scene["robot"].num_joints > 0 and (sim.scene["robot"].root_pos_w[:, 2] < z0).all()  # falls under gravity


def test_missing_robot_file_is_reported():
    with pytest.raises(ConfigError, match="scene.entities.robot: model file not found: /nonexistent/robot.xml"):
        robot_sim(ArticulationCfg(model_file="/nonexistent/robot.xml"), 1)


def test_root_velocity_is_the_centre_of_mass_velocity(t1_env):
    # Isaac Lab's root_lin_vel_b is root_com_lin_vel_b: a base spinning about its centre of mass has none
    robot, n = t1_env.scene["robot"], t1_env.num_envs
    assert robot.body_com_b[0, 0, :2].norm() > 0.01  # off the spin axis through the frame origin
    spin = torch.tensor([0.0, 0.0, 0.0, 0.0, 0.0, 2.0]).repeat(n, 1)
    robot.write_root_state(robot.root_pose_w.clone(), spin, torch.ones(n, dtype=torch.bool))
    t1_env.sim.forward()
    robot.update()
    assert torch.allclose(robot.root_lin_vel_b, torch.zeros(n, 3), atol=1e-5)
    assert torch.allclose(robot.root_ang_vel_w[:, 2], torch.full((n,), 2.0), atol=1e-5)
    t1_env.reset()
