"""The velocity-and-height env configs built on the CPU: the teacher's harness wrench for a known displacement and
velocity (a Warp kernel on the simulation's arrays), the teacher held up by it, and the students' observation
groups."""

import math

import pytest
import torch

from agile.rl_env import ManagerBasedRLEnv
from agile.tasks.velocity_height.g1 import velocity_height_env_cfg as height_cfgs
from agile.utils.math import quat_from_euler_xyz


# -- harness (on the teacher env: the wrench comes from a Warp kernel on the simulation's arrays) ------------

def test_harness_wrench_for_a_known_displacement_and_velocity(teacher_env):
    env = teacher_env
    robot, harness = env.scene["robot"], env.action_manager.get_term("harness")
    pelvis = robot.find_bodies("pelvis")[0][0]
    roll, yaw = 0.1, 1.0
    pose = robot.root_pose_w.clone()
    pose[:, 3:7] = quat_from_euler_xyz(torch.tensor(roll), torch.tensor(0.0), torch.tensor(yaw)).expand(2, 4)
    body_x_w = torch.tensor([math.cos(yaw), math.sin(yaw), 0.0])
    velocity = torch.cat((torch.tensor([0.0, 0.0, 0.2]), 0.5 * body_x_w)).expand(2, 6)  # v_z, ω about body x
    robot.write_root_state(pose, velocity, torch.ones(2, dtype=torch.bool))
    env.sim.forward()
    env.scene.update()
    height_m = robot.root_pos_w[:, 2] - env.scene["height_measurement_sensor"].hit_z_m.mean(dim=1)
    env.command_manager.get_term("base_velocity").height_command_m.copy_(height_m + 0.05)
    robot.body_wrench_w[:, pelvis] = 0.0
    harness.scale_forces(1.0)
    harness.apply_actions()
    harness.apply_wrench()
    wrench = robot.body_wrench_w[:, pelvis].clone()
    force_z = 1000.0 * 0.05 - 100.0 * 0.2  # k_f·Δh - d_f·v_z = 30 N, within ±150 N
    torque = (-300.0 * roll - 50.0 * 0.5) * body_x_w  # -k_t·roll - d_t·ω_x about the body's x axis
    expected = torch.cat((torch.tensor([0.0, 0.0, force_z]), torch.tensor(torque.tolist())))
    assert torch.allclose(wrench, expected.expand(2, 6), atol=1e-3), wrench

    # a push written by an event adds to the harness; it stays until replaced; a reset clears it
    push = torch.tensor([3.0, 0.0, 0.0, 0.0, 1.0, 0.0])
    robot.body_wrench_w[:, pelvis] = push
    harness.scale_forces(0.5)
    for _ in range(2):
        harness.apply_actions()
        harness.apply_wrench()
        assert torch.allclose(robot.body_wrench_w[:, pelvis], (push + 0.5 * expected).expand(2, 6), atol=1e-3)
    robot.body_wrench_w[:, pelvis] = 0.0
    harness.apply_actions()
    harness.apply_wrench()
    assert torch.allclose(robot.body_wrench_w[:, pelvis], (0.5 * expected).expand(2, 6), atol=1e-3)
    harness.scale_forces(1.0)
    env.reset()


# -- the env configs build and step --------------------------------------------------------------------------

def _build(make_cfg, flat_ground: bool = False):
    """The task with 2 envs; `flat_ground` for a test the terrain plays no part in (a registered terrain costs ~8 s
    of CPU to build)."""
    cfg = make_cfg()
    cfg.num_envs = 2
    if flat_ground:
        cfg.scene.terrain, cfg.curriculum.terrain_levels = None, None
    return ManagerBasedRLEnv(cfg, device="cpu")


@pytest.fixture(scope="module")
def teacher_env():
    env = _build(height_cfgs.teacher_env_cfg)
    yield env
    env.close()


def _step_finite(env, steps: int):
    for _ in range(steps):
        obs, reward, _, _, _ = env.step(torch.zeros(env.num_envs, env.action_manager.total_action_dim))
        assert torch.isfinite(reward).all()
        for group in obs.keys():
            assert all(torch.isfinite(obs[group][term]).all() for term in obs[group].keys()), group
    return obs


def test_teacher_steps_held_up_by_the_harness(teacher_env):
    env = teacher_env
    env.reset()
    dims = env.observation_manager.term_dims
    assert sum(dims["policy"].values()) == 4 + 3 + 3 + 3 + 29 + 29 + 12
    assert dims["critic"]["height_scan_feet"] == 70 and dims["critic"]["base_height"] == 1
    assert env.action_manager.total_action_dim == 12
    robot = env.scene["robot"]
    pelvis = robot.find_bodies("pelvis")[0][0]
    torch.manual_seed(0)
    for _ in range(25):  # zero actions: the default pose, held up at the pelvis
        _step_finite(env, 1)
        going_on = env.episode_length_buf > 0  # (an env reset in this step starts unheld)
        assert (robot.body_wrench_w[going_on, pelvis, 2] != 0.0).all()  # the harness pushes
        # (an env may still tip over: its joints reset at up to twice their defaults, and pushes come; the
        # harness holds the height, so no pelvis sinks towards the ground)
        assert (robot.root_pos_w[:, 2] - env.scene["height_measurement_sensor"].hit_z_m.mean(dim=1) > 0.6).all()


@pytest.mark.parametrize("student", ["recurrent_student_env_cfg", "history_student_env_cfg"])
def test_students_see_the_teachers_policy_group_and_have_no_harness(student, teacher_env):
    env = _build(getattr(height_cfgs, student), flat_ground=True)
    assert env.observation_manager.term_dims["teacher"] == teacher_env.observation_manager.term_dims["policy"]
    assert "base_lin_vel" not in env.observation_manager.term_dims["policy"]
    assert "harness" not in env.action_manager.active_terms
    assert "remove_harness" not in env.curriculum_manager.active_terms
    obs = _step_finite(env, 3)
    history = 5 if "history" in student else 1
    assert obs["policy"]["projected_gravity"].shape == (2, 3 * history)
    env.close()
