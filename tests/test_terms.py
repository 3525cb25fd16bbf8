"""Reward, observation and termination terms with hand-computed values."""

import math

import pytest
import torch
from fakes import FakeEnv

from agile.rl_env import mdp
from agile.rl_env.managers import SceneEntityCfg
from agile.utils.math import quat_from_euler_xyz


class _Commands:
    def __init__(self, command):
        self.command = command

    def get_command(self, name):
        return self.command


class _Actions:
    def __init__(self, action, prev, prev_prev):
        self.action, self.prev_action, self.prev_prev_action = action, prev, prev_prev


def _entity(env, **kwargs):
    cfg = SceneEntityCfg("robot", **kwargs)
    cfg.resolve(env)
    return cfg


def test_track_lin_vel_xy_exp():
    env = FakeEnv(num_envs=1)
    env.command_manager = _Commands(torch.tensor([[0.5, 0.0, 0.0]]))
    env.robot.root_lin_vel_b[:] = torch.tensor([0.3, 0.1, 0.0])
    # error = 0.2^2 + 0.1^2 = 0.05 ; exp(-0.05 / 0.25^2)
    value = mdp.track_lin_vel_xy_exp(env, std=0.25, command_name="v", asset_cfg=_entity(env))
    assert value.item() == pytest.approx(math.exp(-0.05 / 0.0625), rel=1e-5)


def test_track_ang_vel_z_exp_and_base_height_exp():
    env = FakeEnv(num_envs=1)
    env.command_manager = _Commands(torch.tensor([[0.0, 0.0, 1.0]]))
    env.robot.root_ang_vel_b[:] = torch.tensor([0.0, 0.0, 0.5])
    assert mdp.track_ang_vel_z_exp(env, std=0.5, command_name="v", asset_cfg=_entity(env)).item() == \
        pytest.approx(math.exp(-1.0), rel=1e-5)
    env.robot.root_pos_w[:, 2] = 0.6
    assert mdp.base_height_exp(env, target_height_m=0.65, std=0.1, asset_cfg=_entity(env)).item() == \
        pytest.approx(math.exp(-0.25), rel=1e-5)


def test_orientation_terms():
    env = FakeEnv(num_envs=1)
    env.robot.projected_gravity_b[:] = torch.tensor([0.6, 0.0, -0.8])
    assert mdp.flat_orientation_l2(env, asset_cfg=_entity(env)).item() == pytest.approx(0.36)
    # bodies tilted by 0.2 rad in roll: |g_xy| = sin(0.2)
    env.robot.body_pose_w[:, 1:, 3:7] = quat_from_euler_xyz(torch.tensor(0.2), torch.tensor(0.0), torch.tensor(0.0))
    feet = _entity(env, body_names="foot_.*")
    expected = math.exp(-2 * math.sin(0.2) ** 2 / 0.1**2)  # two bodies' squared tilts add up in one kernel
    assert mdp.flat_body_orientation_exp(env, std_rad=0.1, asset_cfg=feet).item() == pytest.approx(expected, rel=1e-4)
    assert mdp.bad_orientation(env, limit_angle_rad=0.1, asset_cfg=feet).item()
    assert not mdp.bad_orientation(env, limit_angle_rad=0.3, asset_cfg=feet).item()


def test_joint_limit_terms():
    env = FakeEnv(num_envs=1)
    robot = env.robot
    robot.joint_pos[:] = torch.tensor([1.5, -1.2, 0.0])  # limits are ±1
    assert mdp.joint_pos_limits(env, asset_cfg=_entity(env)).item() == pytest.approx(0.5 + 0.2)
    robot.soft_joint_pos_limits = robot.joint_pos_limits * 0.9  # Isaac Lab soft limits, factor 0.9 about 0
    robot.joint_pos[:] = torch.tensor([0.95, -0.5, 0.0])
    assert mdp.joint_pos_limits(env, asset_cfg=_entity(env)).item() == pytest.approx(0.05)
    robot.soft_joint_pos_limits = robot.joint_pos_limits.clone()
    robot.joint_vel[:] = torch.tensor([9.5, -20.0, 1.0])  # limit 10, soft 0.9 -> 9
    assert mdp.joint_vel_limits(env, soft_ratio=0.9, asset_cfg=_entity(env)).item() == pytest.approx(0.5 + 1.0)
    robot.computed_torque[:] = torch.tensor([30.0, -5.0, 1.0])
    robot.applied_torque[:] = torch.tensor([20.0, -5.0, 1.0])
    assert mdp.applied_torque_limits(env, asset_cfg=_entity(env)).item() == pytest.approx(10.0)
    assert mdp.joint_torques_l2(env, asset_cfg=_entity(env, joint_names="a")).item() == pytest.approx(400.0)


def test_action_rate_terms():
    env = FakeEnv(num_envs=1)
    env.action_manager = _Actions(torch.tensor([[1.0, 2.0]]), torch.tensor([[0.5, 1.0]]), torch.tensor([[0.0, 1.0]]))
    assert mdp.action_rate_l2(env).item() == pytest.approx(0.25 + 1.0)
    # second difference: (1 - 1 + 0, 2 - 2 + 1) = (0, 1)
    assert mdp.action_rate_rate_l2(env).item() == pytest.approx(1.0)


def test_feet_terms():
    env = FakeEnv(num_envs=1)
    robot = env.robot
    robot.body_pose_w[0, 1, 3:7] = quat_from_euler_xyz(torch.tensor(0.1), torch.tensor(0.0), torch.tensor(0.3))
    robot.body_pose_w[0, 2, 3:7] = quat_from_euler_xyz(torch.tensor(0.0), torch.tensor(0.0), torch.tensor(-0.1))
    robot.body_pose_w[0, 1, :3] = torch.tensor([0.0, 0.15, 0.0])
    robot.body_pose_w[0, 2, :3] = torch.tensor([0.0, -0.15, 0.0])
    feet = _entity(env, body_names=["foot_l", "foot_r"], preserve_order=True)
    assert mdp.feet_roll_l2(env, asset_cfg=feet).item() == pytest.approx(0.01, rel=1e-4)
    assert mdp.feet_yaw_diff_l2(env, asset_cfg=feet).item() == pytest.approx(0.16, rel=1e-4)
    # feet yawed 0.3 and -0.1 against a base yawed 0.1: (0.2² + 0.2²); toes in or out cost the same
    robot.body_pose_w[0, 0, 3:7] = quat_from_euler_xyz(torch.tensor(0.0), torch.tensor(0.0), torch.tensor(0.1))
    base = _entity(env, body_names="base")
    yaw_cost = mdp.feet_yaw_mean_vs_base(env, feet_asset_cfg=feet, base_body_cfg=base)
    assert yaw_cost.item() == pytest.approx(0.08, rel=1e-3)
    with pytest.raises(ValueError, match="one base body"):
        mdp.feet_yaw_mean_vs_base(env, feet_asset_cfg=feet, base_body_cfg=feet)
    assert mdp.feet_distance_from_ref(env, ref_distance_m=0.2, asset_cfg=feet).item() == pytest.approx(0.1, rel=1e-4)


def test_time_out_and_height():
    env = FakeEnv(num_envs=2)
    env.episode_length_buf[:] = torch.tensor([499, 500])
    assert mdp.time_out(env).tolist() == [False, True]
    env.robot.root_pos_w[:, 2] = torch.tensor([0.3, 0.5])
    assert mdp.root_height_below_minimum(env, minimum_height_m=0.35, asset_cfg=_entity(env)).tolist() == [True, False]


def test_joint_pos_rel_selects_joints():
    env = FakeEnv(num_envs=1)
    env.robot.joint_pos[:] = torch.tensor([0.5, 0.6, 0.7])
    env.robot.default_joint_pos[:] = torch.tensor([0.1, 0.1, 0.1])
    value = mdp.joint_pos_rel(env, asset_cfg=_entity(env, joint_names=["c", "a"], preserve_order=True))
    assert value.tolist()[0] == pytest.approx([0.6, 0.4])


def test_body_acc_l2_adds_angular_acceleration_and_clamps():
    env = FakeEnv(num_envs=2)
    env.robot.body_lin_acc_w = torch.zeros(2, 3, 3)
    env.robot.body_ang_acc_w = torch.zeros(2, 3, 3)
    env.robot.body_lin_acc_w[0, 0] = torch.tensor([3.0, 4.0, 0.0])
    env.robot.body_ang_acc_w[0, 0] = torch.tensor([0.0, 0.0, 2.0])
    env.robot.body_ang_acc_w[0, 1] = torch.tensor([1.0, 0.0, 0.0])  # not selected
    env.robot.body_lin_acc_w[1, 0] = torch.tensor([2000.0, 0.0, 0.0])  # a violent contact
    base = _entity(env, body_names="base")
    assert mdp.body_acc_l2(env, base).tolist() == pytest.approx([25.0 + 4.0, 1e6])
