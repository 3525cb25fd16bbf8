"""The pick-and-place trajectory file and TrackingCommand, against a hand-written file with hand-computed values."""

import math

import numpy as np
import pytest
import torch
from fakes import FakeEnv

from agile.motion.trajectory_file import PHASES, load_trajectory, resample, sample
from agile.tasks.pick_place.mdp.tracking_command import TrackingCommand, TrackingCommandCfg

S45, C45 = math.sin(math.pi / 8), math.cos(math.pi / 8)  # half-angles of 45° and 90°
S90, C90 = math.sin(math.pi / 4), math.cos(math.pi / 4)

HAND_WRITTEN = """\
format_version: 1
description: two joints, three keyframes
anchor_body: base
joint_names: [b, a]
frames:
  - {time_s: 0.0, phase: approach, joint_pos: [0.0, 0.0], object_pos_m: [0.4, 0.0, 0.8],
     object_quat_xyzw: [0, 0, 0, 1], anchor_pos_m: [0, 0, 1], anchor_quat_xyzw: [0, 0, 0, 1]}
  - {time_s: 1.0, phase: carry, joint_pos: [1.0, -2.0], object_pos_m: [0.4, 0.0, 1.0],
     object_quat_xyzw: [0, 0, %.9f, %.9f], anchor_pos_m: [0, 0, 1], anchor_quat_xyzw: [0, 0, 0, 1]}
  - {time_s: 3.0, phase: release, joint_pos: [1.0, 2.0], object_pos_m: [0.4, 0.4, 1.0],
     object_quat_xyzw: [0, 0, %.9f, %.9f], anchor_pos_m: [0, 0, 1], anchor_quat_xyzw: [0, 0, 0, 1]}
""" % (S90, C90, S90, C90)


@pytest.fixture
def trajectory_file(tmp_path):
    path = tmp_path / "hand_written.yaml"
    path.write_text(HAND_WRITTEN)
    return path


def test_sampling_interpolates_between_keyframes(trajectory_file):
    trajectory = load_trajectory(trajectory_file)
    at = sample(trajectory, np.array([0.0, 0.5, 1.0, 2.0, 3.0, 4.0]))
    np.testing.assert_allclose(at.joint_pos, [[0, 0], [0.5, -1], [1, -2], [1, 0], [1, 2], [1, 2]])
    np.testing.assert_allclose(at.object_pos_m[:, 1:], [[0, 0.8], [0, 0.9], [0, 1], [0.2, 1], [0.4, 1], [0.4, 1]])
    # halfway from no rotation to 90° about z: 45° (slerp; a linear blend would not be a unit quaternion)
    np.testing.assert_allclose(at.object_quat_xyzw[1], [0, 0, S45, C45], atol=1e-9)
    np.testing.assert_allclose(at.object_quat_xyzw[3], [0, 0, S90, C90], atol=1e-9)
    quarter = sample(trajectory, np.array([0.25])).object_quat_xyzw[0]  # 22.5°: a normalised blend gives 22.2°
    np.testing.assert_allclose(quarter, [0, 0, math.sin(math.pi / 16), math.cos(math.pi / 16)], atol=1e-9)
    assert [PHASES[p] for p in at.phase] == ["approach", "approach", "carry", "carry", "release", "release"]


def test_resampling_at_the_control_step(trajectory_file):
    frames = resample(load_trajectory(trajectory_file), 0.02)
    assert len(frames.time_s) == 151  # 0 .. 3 s
    np.testing.assert_allclose(frames.joint_pos[25], [0.5, -1.0])
    np.testing.assert_allclose(frames.joint_pos[-1], [1.0, 2.0])


@pytest.mark.parametrize("edit, message", [
    (("phase: carry", "phase: lift"), "frames[1].phase 'lift' is not a phase: ['approach', 'grasp'"),
    (("time_s: 3.0", "time_s: 0.5"), "time_s must start at 0 and increase strictly"),
    (("joint_pos: [1.0, 2.0]", "joint_pos: [1.0]"), "frames[2].joint_pos has 1 values, expected 2"),
    (("object_pos_m: [0.4, 0.4, 1.0],", ""), "misses ['object_pos_m']"),
    (("format_version: 1", "format_version: 7"), "format_version 7, this agile reads 1"),
])
def test_a_bad_file_is_refused_naming_the_field(tmp_path, edit, message):
    path = tmp_path / "bad.yaml"
    path.write_text(HAND_WRITTEN.replace(*edit))
    with pytest.raises(ValueError) as err:
        load_trajectory(path)
    assert message in str(err.value)


def command_env(num_envs: int = 2) -> FakeEnv:
    env = FakeEnv(num_envs, joint_names=("a", "b", "c"))
    env.step_dt = 0.02
    env.env_origins = torch.tensor([[0.0, 0.0, 0.0], [5.0, 0.0, 0.0]])[:num_envs]
    return env


def test_tracking_command_follows_the_file_frame_by_frame(trajectory_file):
    env = command_env()
    cfg = TrackingCommandCfg(trajectory_files=[str(trajectory_file)], start_step_range=(25, 25),
                             reset_joints_to_reference=False, object_name=None)
    command = TrackingCommand(cfg, env)
    command.reset(torch.tensor([True, True]))
    torch.testing.assert_close(command.command, torch.tensor([[0.5, -1.0], [0.5, -1.0]]))
    assert command.joint_names == ["b", "a"]
    env.robot.joint_pos[:] = torch.tensor([10.0, 20.0, 30.0])
    torch.testing.assert_close(command.robot_joint_pos, torch.tensor([[20.0, 10.0]] * 2))  # by name
    torch.testing.assert_close(command.object_pos_w, torch.tensor([[0.4, 0.0, 0.9], [5.4, 0.0, 0.9]]))
    assert not command.in_hand.any()
    for _ in range(100):  # frame 125 = 2.5 s: carrying, 0.75 of the way from [1, -2] to [1, 2]
        command.compute(env.step_dt)
    torch.testing.assert_close(command.command, torch.tensor([[1.0, 1.0]] * 2))
    assert command.in_hand.all()
    torch.testing.assert_close(command.progress, torch.full((2,), 125 / 150))
    for _ in range(30):  # past the end: the last frame is held
        command.compute(env.step_dt)
    assert (command.time_steps == 150).all()
    torch.testing.assert_close(command.command, torch.tensor([[1.0, 2.0]] * 2))
    torch.testing.assert_close(command.final_joint_pos, torch.tensor([[1.0, 2.0]] * 2))
    torch.testing.assert_close(command.progress, torch.ones(2))
    assert not command.in_hand.any()
    assert (command.steps_since_release == 0).all()  # the release keyframe is the last: released at frame 150


def test_tracking_command_refuses_joints_the_robot_lacks(trajectory_file, tmp_path):
    path = tmp_path / "other.yaml"
    path.write_text(HAND_WRITTEN.replace("joint_names: [b, a]", "joint_names: [b, wrist]"))
    with pytest.raises(ValueError, match=r"trajectory joints \['wrist'\] are not in robot 'robot'"):
        TrackingCommand(TrackingCommandCfg(trajectory_files=[str(path)]), command_env())


def test_shipped_trajectories_are_what_the_script_makes(tmp_path):
    """They load, start with the cube where the scene puts it, and are reproduced by their script."""
    import make_pick_place_trajectories

    from agile.assets.tabletop import CUBE_START_POS_M
    from agile.motion.trajectory_file import SHIPPED_TRAJECTORIES_DIR

    make_pick_place_trajectories.main(["--out", str(tmp_path)])
    shipped = sorted(p.name for p in SHIPPED_TRAJECTORIES_DIR.glob("*.yaml"))
    assert shipped == sorted(p.name for p in tmp_path.glob("*.yaml")) and len(shipped) == 3
    for name in shipped:
        assert (SHIPPED_TRAJECTORIES_DIR / name).read_text() == (tmp_path / name).read_text(), name
        trajectory = load_trajectory(name.removesuffix(".yaml"))
        np.testing.assert_allclose(trajectory.object_pos_m[0], CUBE_START_POS_M)
        assert [PHASES[p] for p in sorted(set(trajectory.phase))] == list(PHASES)


def test_a_missing_path_is_an_error_and_a_bare_name_is_a_shipped_trajectory(tmp_path):
    from agile.motion.trajectory_file import resolve_trajectory_file

    # a path with a folder that does not exist is not replaced by the shipped file of the same name
    with pytest.raises(FileNotFoundError, match=r"trajectory file '.*nope/pick_place_left.yaml' not found"):
        resolve_trajectory_file(str(tmp_path / "nope" / "pick_place_left.yaml"))
    assert resolve_trajectory_file("pick_place_left").name == "pick_place_left.yaml"
    assert resolve_trajectory_file("pick_place_left.yaml").name == "pick_place_left.yaml"
    with pytest.raises(FileNotFoundError, match=r"Shipped trajectory files: \[.*'pick_place_left'"):
        resolve_trajectory_file("pick_place_nowhere")
