"""Motion tracking: the CSV converter, the stored forward kinematics against the simulator's, the motion command
(reference state at resets, anchor-relative targets, adaptive sampling) and its terms with hand-computed values."""

import math
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
import torch
from fakes import FakeEnv

import agile.tasks  # noqa: F401  (registers the tasks)
from agile.assets.unitree_g1 import g1_beyondmimic_actuators, g1_robot_cfg
from agile.motion import load_motion
from agile.motion.convert import G1_CSV_JOINT_NAMES, RootAndJoints, convert_csv, write_motion_csv
from agile.tasks.motion_tracking import mdp
from agile.rl_env.managers import SceneEntityCfg
from agile.utils.math import quat_from_euler_xyz, quat_mul, quat_rotate

INPUT_FPS, OUTPUT_FPS = 30.0, 50.0


def sine_csv(path, joint_order):
    """A 2 s motion at 30 fps in the public layout: joint i (of G1_CSV_JOINT_NAMES) = a_i sin(w_i t), the root
    moving along x as 0.1 sin(2t) at 0.75 m and turning by yaw 0.5 sin(1.5t); columns in `joint_order`."""
    t = np.arange(61) / INPUT_FPS
    amp = 0.05 + 0.01 * np.arange(29)
    freq = 1.0 + 0.1 * np.arange(29)
    joints = amp * np.sin(freq * t[:, None])
    root = np.stack([0.1 * np.sin(2 * t), np.zeros_like(t), np.full_like(t, 0.75)], 1)
    yaw = 0.5 * np.sin(1.5 * t)
    quat = np.stack([np.zeros_like(t), np.zeros_like(t), np.sin(yaw / 2), np.cos(yaw / 2)], 1)
    columns = [G1_CSV_JOINT_NAMES.index(n) for n in joint_order]
    write_motion_csv(path, RootAndJoints(INPUT_FPS, joint_order, root, quat, joints[:, columns]))
    return amp, freq


def test_converter_remaps_joints_resamples_and_differentiates(tmp_path):
    shuffled = list(reversed(G1_CSV_JOINT_NAMES))  # a CSV whose columns are in another order
    amp, freq = sine_csv(tmp_path / "sine.csv", shuffled)
    motion = convert_csv(tmp_path / "sine.csv", INPUT_FPS, OUTPUT_FPS, g1_robot_cfg(g1_beyondmimic_actuators()),
                         csv_joint_names=shuffled)
    assert motion.fps == OUTPUT_FPS and motion.num_frames == 101  # 2 s at 50 Hz
    t = np.arange(101) / OUTPUT_FPS
    order = [G1_CSV_JOINT_NAMES.index(n) for n in motion.joint_names]  # the robot's joint order
    expected_pos = amp[order] * np.sin(freq[order] * t[:, None])
    expected_vel = amp[order] * freq[order] * np.cos(freq[order] * t[:, None])
    np.testing.assert_allclose(motion.joint_pos, expected_pos, atol=2e-4)
    inner = slice(1, -1)  # one-sided differences at the ends are first order
    np.testing.assert_allclose(motion.joint_vel[inner], expected_vel[inner], atol=3e-3)
    pelvis = motion.body_names.index("pelvis")
    np.testing.assert_allclose(motion.body_ang_vel_w[inner, pelvis, 2], 0.75 * np.cos(1.5 * t[inner]), atol=2e-3)
    np.testing.assert_allclose(motion.body_pos_w[:, pelvis, 0], 0.1 * np.sin(2 * t), atol=2e-4)


def test_converter_names_the_missing_joints(tmp_path):
    names = list(G1_CSV_JOINT_NAMES)
    names[3] = "left_knee"  # misspelt in the CSV's joint list
    sine_csv(tmp_path / "sine.csv", list(G1_CSV_JOINT_NAMES))
    with pytest.raises(ValueError, match="left_knee_joint"):
        convert_csv(tmp_path / "sine.csv", INPUT_FPS, OUTPUT_FPS, g1_robot_cfg(g1_beyondmimic_actuators()), csv_joint_names=names)


def test_shipped_motions_stand_on_the_ground():
    for name in ("g1_squat_arm_swing", "g1_step_turn"):
        motion = load_motion(name)
        feet = [motion.body_names.index(f) for f in ("left_ankle_roll_link", "right_ankle_roll_link")]
        sole_z = motion.body_pos_w[:, feet, 2] - 0.037  # ankle-roll frame above the foot's sole
        assert np.abs(sole_z.min(axis=1)).max() < 1e-3, name  # the lower foot touches the ground in every frame
        assert np.abs(np.diff(motion.joint_pos, axis=0)).max() < 0.1, name


# -- the motion command in the env -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def env():
    overrides = ["commands.motion.pose_range={}", "commands.motion.velocity_range={}",
                 "commands.motion.joint_position_range=(0.0, 0.0)", "commands.motion.adaptive_alpha=1.0",
                 # the torso's randomised centre of mass moves its COM velocity away from the nominal model's
                 "events.base_com=null"]
    env = gym.make("MotionTracking-G1-v0", num_envs=4, device="cpu", overrides=overrides).unwrapped
    yield env
    env.close()


def test_reset_puts_the_robot_in_the_reference_and_stored_kinematics_match_the_simulator(env):
    env.reset()
    cmd = env.command_manager.get_term("motion")
    robot = cmd.robot
    torch.testing.assert_close(robot.joint_pos, cmd.joint_pos)
    # body poses and velocities that the simulator computes from the written joint state, against the file's
    torch.testing.assert_close(cmd.robot_body_pos_w, cmd.body_pos_w, atol=1e-4, rtol=0)
    dot = (cmd.robot_body_quat_w * cmd.body_quat_w).sum(-1).abs()
    assert (dot > 1 - 1e-6).all()
    torch.testing.assert_close(cmd.robot_body_lin_vel_w, cmd.body_lin_vel_w, atol=1e-3, rtol=0)
    torch.testing.assert_close(cmd.robot_body_ang_vel_w, cmd.body_ang_vel_w, atol=1e-3, rtol=0)


def test_relative_targets_follow_a_robot_moved_rigidly_in_yaw(env):
    env.reset()
    cmd = env.command_manager.get_term("motion")
    robot = cmd.robot
    yaw = quat_from_euler_xyz(*torch.tensor([0.0, 0.0, math.pi / 2]).repeat(4, 1).unbind(-1))
    shift = torch.tensor([0.3, -0.2, 0.0])
    pose = robot.root_pose_w.clone()
    pose[:, :3] = quat_rotate(yaw, pose[:, :3] - env.env_origins) + env.env_origins + shift
    pose[:, 3:] = quat_mul(yaw, pose[:, 3:])
    all_envs = torch.ones(4, dtype=torch.bool)
    robot.write_root_state(pose, torch.zeros(4, 6), all_envs)
    env.sim.forward(all_envs)
    robot.update()
    cmd._update_command()
    # the whole robot is the reference turned and shifted: its bodies are exactly on their relative targets
    torch.testing.assert_close(cmd.body_pos_relative_w, cmd.robot_body_pos_w, atol=1e-4, rtol=0)
    dot = (cmd.body_quat_relative_w * cmd.robot_body_quat_w).sum(-1).abs()
    assert (dot > 1 - 1e-6).all()
    params = {"command_name": "motion", "std": 0.3}
    assert torch.allclose(mdp.motion_relative_body_position_error_exp(env, **params), torch.ones(4), atol=1e-4)
    assert (mdp.motion_global_anchor_position_error_exp(env, **params) < 0.9).all()


def test_adaptive_sampling_favours_the_failed_segment(env):
    cmd = env.command_manager.get_term("motion")
    all_envs = torch.ones(4, dtype=torch.bool)
    cmd.bin_failed_count.zero_()
    uniform = cmd.sampling_probabilities()
    torch.testing.assert_close(uniform, torch.full_like(uniform, 1.0 / cmd.bin_count))
    failed_bin = 3
    cmd.time_steps.fill_(int((failed_bin + 0.5) * cmd.num_frames / cmd.bin_count))
    env.termination_manager.terminated.fill_(True)  # every episode failed in that segment
    cmd.reset(all_envs)
    env.termination_manager.terminated.fill_(False)
    cmd.compute(env.step_dt)  # folds the step's failures into the average (alpha = 1 here)
    probs = cmd.sampling_probabilities()
    weight = 4 + 0.8 / cmd.bin_count
    assert probs[failed_bin].item() == pytest.approx(weight / (4 + 0.8), rel=1e-5)
    starts = []
    for _ in range(50):
        cmd.reset(all_envs)  # no failures now: only draws
        starts.append(cmd._frame_bins().clone())
    share = (torch.cat(starts) == failed_bin).float().mean().item()
    assert share > 0.7  # 0.85 expected; a uniform draw gives 1/bins


def test_a_fixed_start_frame_starts_every_episode_there():
    env = gym.make("MotionTracking-G1-v0", num_envs=2, device="cpu",
                   overrides=["commands.motion.start_frame=0", "commands.motion.pose_range={}",
                              "commands.motion.joint_position_range=(0.0, 0.0)"]).unwrapped
    env.reset()
    cmd = env.command_manager.get_term("motion")
    assert (cmd.time_steps == 0).all()
    torch.testing.assert_close(env.scene["robot"].joint_pos, cmd.motion_joint_pos[0].expand(2, -1))
    with pytest.raises(ValueError, match="start_frame 401; the motion has 401 frames"):
        gym.make("MotionTracking-G1-v0", num_envs=2, device="cpu", overrides=["commands.motion.start_frame=401"])


def test_time_outs_are_not_failures(env):
    cmd = env.command_manager.get_term("motion")
    cmd.bin_failed_count.zero_()
    env.termination_manager.terminated.fill_(False)
    env.termination_manager.time_outs.fill_(True)
    cmd.reset(torch.ones(4, dtype=torch.bool))
    cmd.compute(env.step_dt)
    assert cmd.bin_failed_count.sum().item() == 0.0
    env.termination_manager.time_outs.fill_(False)


# -- terms with hand-computed values ------------------------------------------------------------------------------

def fake_command(num_envs=2, bodies=("pelvis", "left_hand", "right_hand")):
    """Reference and robot at rest on identity poses; tests move one of them."""
    n, b = num_envs, len(bodies)
    identity = torch.tensor([0.0, 0.0, 0.0, 1.0])
    tensors = {name: torch.zeros(n, b, 3) for name in ("body_pos_relative_w", "robot_body_pos_w", "body_lin_vel_w",
                                                          "robot_body_lin_vel_w", "body_ang_vel_w",
                                                          "robot_body_ang_vel_w")}
    tensors.update({name: identity.repeat(n, b, 1) for name in ("body_quat_relative_w", "robot_body_quat_w")})
    tensors.update(anchor_pos_w=torch.zeros(n, 3), robot_anchor_pos_w=torch.zeros(n, 3),
                   anchor_quat_w=identity.repeat(n, 1), robot_anchor_quat_w=identity.repeat(n, 1))
    return SimpleNamespace(body_names=list(bodies), **tensors)


def env_with(command):
    env = FakeEnv(num_envs=2)
    env.command_manager = SimpleNamespace(get_term=lambda name: command)
    return env


def test_tracking_rewards_by_hand():
    cmd = fake_command()
    env = env_with(cmd)
    cmd.robot_anchor_pos_w[0] = torch.tensor([0.3, 0.0, 0.4])  # 0.5 m off
    assert mdp.motion_global_anchor_position_error_exp(env, "motion", std=0.5).tolist() == pytest.approx(
        [math.exp(-0.25 / 0.25), 1.0])
    cmd.robot_anchor_quat_w[1] = quat_from_euler_xyz(torch.tensor(0.0), torch.tensor(0.0), torch.tensor(0.6))
    assert mdp.motion_global_anchor_orientation_error_exp(env, "motion", std=0.4).tolist() == pytest.approx(
        [1.0, math.exp(-0.36 / 0.16)], rel=1e-5)
    # one of three bodies 0.3 m off: the squared error averages over the bodies
    cmd.robot_body_pos_w[0, 1] = torch.tensor([0.0, 0.3, 0.0])
    assert mdp.motion_relative_body_position_error_exp(env, "motion", std=0.3).tolist() == pytest.approx(
        [math.exp(-0.03 / 0.09), 1.0], rel=1e-5)
    assert mdp.motion_relative_body_position_error_exp(env, "motion", std=0.3, body_names=["left_hand"])[0].item() \
        == pytest.approx(math.exp(-1.0), rel=1e-5)
    cmd.robot_body_quat_w[1, 2] = quat_from_euler_xyz(torch.tensor(0.3), torch.tensor(0.0), torch.tensor(0.0))
    assert mdp.motion_relative_body_orientation_error_exp(env, "motion", std=0.4)[1].item() == pytest.approx(
        math.exp(-(0.09 / 3) / 0.16), rel=1e-5)
    cmd.body_lin_vel_w[1] = torch.tensor([1.0, 0.0, 0.0])  # every body 1 m/s too slow
    assert mdp.motion_global_body_linear_velocity_error_exp(env, "motion", std=1.0)[1].item() == pytest.approx(
        math.exp(-1.0), rel=1e-5)
    cmd.robot_body_ang_vel_w[0, 0] = torch.tensor([0.0, 0.0, 3.0])
    assert mdp.motion_global_body_angular_velocity_error_exp(env, "motion", std=3.0)[0].item() == pytest.approx(
        math.exp(-(9.0 / 3) / 9.0), rel=1e-5)
    with pytest.raises(ValueError, match="not tracked"):
        mdp.motion_relative_body_position_error_exp(env, "motion", std=0.3, body_names=["head"])


def test_tracking_terminations_by_hand():
    cmd = fake_command()
    env = env_with(cmd)
    cmd.robot_anchor_pos_w[:, 2] = torch.tensor([0.2, -0.3])
    assert mdp.bad_anchor_pos_z_only(env, "motion", threshold_m=0.25).tolist() == [False, True]
    # tilted by 40 deg: gravity's z in the anchor frame changes by 1 - cos 40 = 0.234; by 100 deg: 1.17
    tilt = torch.tensor([math.radians(40.0), math.radians(100.0)])
    cmd.robot_anchor_quat_w[:] = quat_from_euler_xyz(tilt, torch.zeros(2), torch.zeros(2))
    assert mdp.bad_anchor_ori(env, "motion", threshold=0.8).tolist() == [False, True]
    assert mdp.bad_anchor_ori(env, "motion", threshold=0.2).tolist() == [True, True]
    cmd.robot_body_pos_w[0, 2, 2] = 0.3  # right hand 0.3 m above its target
    assert mdp.bad_motion_body_pos_z_only(env, "motion", threshold_m=0.25, body_names=["right_hand"]).tolist() \
        == [True, False]
    assert mdp.bad_motion_body_pos_z_only(env, "motion", threshold_m=0.25, body_names=["left_hand"]).tolist() \
        == [False, False]


def test_anchor_observations_by_hand():
    cmd = fake_command()
    env = env_with(cmd)
    yaw = quat_from_euler_xyz(torch.tensor(0.0), torch.tensor(0.0), torch.tensor(math.pi / 2))
    cmd.robot_anchor_quat_w[:] = yaw  # robot turned left by 90 deg; the reference 1 m ahead along world x
    cmd.anchor_pos_w[:] = torch.tensor([1.0, 0.0, 0.0])
    torch.testing.assert_close(mdp.motion_anchor_pos_b(env, "motion"), torch.tensor([[0.0, -1.0, 0.0]] * 2),
                               atol=1e-6, rtol=0)
    # reference orientation in the robot frame: a -90 deg yaw, first two matrix columns row by row
    expected = torch.tensor([0.0, 1.0, -1.0, 0.0, 0.0, 0.0])  # R = [[0, 1, 0], [-1, 0, 0], [0, 0, 1]]
    torch.testing.assert_close(mdp.motion_anchor_ori_b(env, "motion")[0], expected, atol=1e-6, rtol=0)


def test_joint_default_randomisation_moves_defaults_and_action_offsets_together():
    torch.manual_seed(0)
    env = FakeEnv(num_envs=2)
    action = SimpleNamespace(offset=torch.zeros(2, 3), joint_ids=torch.tensor([0, 1, 2]))
    env.action_manager = SimpleNamespace(get_term=lambda name: action)
    mdp.randomize_joint_default_pos(env, torch.tensor([True, False]), pos_distribution_params=(-0.01, 0.01),
                                    asset_cfg=SceneEntityCfg("robot"))
    defaults = env.robot.default_joint_pos
    assert (defaults[0].abs() <= 0.01).all() and (defaults[0] != 0).all() and (defaults[1] == 0).all()
    torch.testing.assert_close(action.offset, defaults)


# -- shipped policies: one per shipped motion --------------------------------------------------------------------

def test_a_shipped_policy_per_shipped_motion_and_none_for_a_users_file():
    from agile.motion.motion_file import SHIPPED_MOTIONS_DIR

    env_cfg = agile.tasks.load_cfgs("MotionTracking-G1-v0")[0]
    default = agile.tasks.pretrained_policy("MotionTracking-G1-v0")
    assert default.name == f"MotionTracking-G1-v0.{env_cfg.commands.motion.motion_file}.pt"
    assert agile.tasks.pretrained_policy("Tracking-Flat-G1-v0") == default  # two IDs, one task
    for motion in sorted(p.stem for p in SHIPPED_MOTIONS_DIR.glob("*.npz")):
        env_cfg.commands.motion.motion_file = motion
        assert agile.tasks.pretrained_policy("MotionTracking-G1-v0", env_cfg).name == \
            f"MotionTracking-G1-v0.{motion}.pt"
    env_cfg.commands.motion.motion_file = "/data/my_dance.npz"  # a policy of a shipped motion would not track it
    assert agile.tasks.pretrained_policy("MotionTracking-G1-v0", env_cfg) is None
    env_cfg.commands.motion.motion_file = "g1_step_turn.npz"
    assert agile.tasks.pretrained_policy("MotionTracking-G1-v0", env_cfg) is None


def test_eval_without_a_checkpoint_runs_the_policy_of_the_chosen_motion(tmp_path, capsys):
    from agile.run import eval as eval_script

    out = tmp_path / "eval.json"
    eval_script.main(["--task", "MotionTracking-G1-v0", "--device", "cpu", "--num_envs", "2", "--episode_length_s",
                      "0.2", "--out", str(out), "env.commands.motion.motion_file=g1_step_turn"])
    import json

    result = json.loads(out.read_text())
    assert result["checkpoint"].endswith("MotionTracking-G1-v0.g1_step_turn.pt")
    assert set(result["episode_metrics"]) == {"motion/body_pos_error_m", "motion/joint_pos_error_rad"}
