"""Left-right mirroring: an involution, and the same as mirroring the robot's state in the simulation."""

import gymnasium as gym
import pytest
import torch
from tensordict import TensorDict

import agile.tasks  # noqa: F401
from agile.rl_env.mdp.symmetry import _swap_side, body_mirror, group_mirror, lr_mirror, mirror_name
from agile.rl import flatten_groups

TASKS = ["Velocity-T1-v0", "Velocity-G1-History-v0", "Velocity-Flat-Go1-v0"]


@pytest.fixture(scope="module", params=TASKS)
def env(request):
    # randomised centres of mass make each world's robot asymmetric (and the base velocity of the COM with them)
    env = gym.make(request.param, num_envs=2, device="cpu",
                   overrides=["observations.policy.enable_corruption=False", "events.body_com=null",
                              "events.base_com=null"]).unwrapped
    yield env
    env.close()


def test_side_swap():
    assert _swap_side("Left_Hip_Roll") == "Right_Hip_Roll"
    assert _swap_side("right_wrist_yaw_joint") == "left_wrist_yaw_joint"
    assert _swap_side("waist_yaw_joint") == "waist_yaw_joint"


def test_quadruped_leg_prefixes_and_side_letters():
    """A quadruped's legs (Unitree's FL_/FR_/RL_/RR_) and T1's arm links (AL1/AR1) pair up; names without a side
    are their own mirror."""
    assert [mirror_name(n) for n in ("FL_hip_joint", "FR_calf", "RL_thigh_joint", "RR_calf", "HL_foot")] == \
        ["FR_hip_joint", "FL_calf", "RR_thigh_joint", "RL_calf", "HR_foot"]
    assert [mirror_name(n) for n in ("AL1", "AR3", "left_knee_joint", "trunk", "Waist", "FRONT_camera")] == \
        ["AR1", "AL3", "right_knee_joint", "trunk", "Waist", "FRONT_camera"]
    assert body_mirror(["trunk", "FR_calf", "FL_calf", "RR_calf", "RL_calf"]) == [0, 2, 1, 4, 3]


def test_mirroring_twice_is_the_identity(env):
    obs = flatten_groups(env.obs_buf)
    obs = TensorDict({k: torch.randn_like(obs[k]) for k in obs.keys()}, batch_size=[env.num_envs])
    actions = torch.randn(env.num_envs, env.action_manager.total_action_dim)
    obs_aug, actions_aug = lr_mirror(env, obs, actions)
    assert obs_aug.batch_size[0] == 2 * env.num_envs
    twice, twice_actions = lr_mirror(env, obs_aug[env.num_envs:], actions_aug[env.num_envs:])
    for key in obs.keys():
        assert torch.equal(twice[key][env.num_envs:], obs[key])
        assert not torch.equal(obs_aug[key][env.num_envs:], obs[key])
    assert torch.equal(twice_actions[env.num_envs:], actions)
    assert lr_mirror(env, None, actions)[0] is None and lr_mirror(env, obs, None)[1] is None


def test_default_pose_is_symmetric(env):
    mirror = group_mirror(env)
    q0 = env.scene["robot"].default_joint_pos[0]
    perm, sign = torch.tensor(mirror.joint_perm), torch.tensor(mirror.joint_sign)
    assert torch.allclose(q0[perm] * sign, q0, atol=1e-6)


def test_mirror_of_observations_equals_observations_of_the_mirrored_state(env):
    torch.manual_seed(1)
    robot, n = env.scene["robot"], env.num_envs
    mirror = group_mirror(env)
    perm, sign = torch.tensor(mirror.joint_perm), torch.tensor(mirror.joint_sign)
    command_term = env.command_manager.get_term("base_velocity")

    def set_state(q, qd, quat, com_vel, command, action):
        pose = robot.root_pose_w.clone()
        pose[:, :3] = torch.tensor([0.3, 0.2, 0.7])
        pose[:, 3:7] = quat
        everyone = torch.ones(n, dtype=torch.bool)
        robot.write_root_state(pose, com_vel, everyone)
        robot.write_joint_state(q, qd, everyone)
        env.sim.forward()
        robot.update()
        command_term.vel_command_b[:] = command
        env.action_manager.action[:] = action
        return env.observation_manager.compute_group("critic")

    q = robot.default_joint_pos + 0.2 * torch.randn_like(robot.joint_pos)
    qd = torch.randn_like(robot.joint_vel)
    quat = torch.nn.functional.normalize(torch.tensor([0.1, 0.05, 0.3, 0.95]).repeat(n, 1), dim=-1)
    com_vel = torch.randn(n, 6)
    command = torch.tensor([0.4, 0.2, -0.5]).repeat(n, 1)
    action = torch.randn(n, env.action_manager.total_action_dim)
    obs = set_state(q, qd, quat, com_vel, command, action)

    # the same state reflected in the robot's sagittal (x-z) plane
    flip_vec = torch.tensor([1.0, -1.0, 1.0])
    mirrored = set_state(
        (q[:, perm] * sign), (qd[:, perm] * sign), quat * torch.tensor([-1.0, 1.0, -1.0, 1.0]),
        torch.cat((com_vel[:, :3] * flip_vec, com_vel[:, 3:] * -flip_vec), dim=1),
        command * torch.tensor([1.0, -1.0, -1.0]), group_mirror(env).apply(action, group_mirror(env).action))
    assert torch.allclose(mirror.apply(obs, mirror.groups["critic"]), mirrored, atol=2e-3)
