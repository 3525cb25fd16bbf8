"""play.py --video_reference: the motion's reference drawn as a kinematic copy of the robot beside it (CPU)."""

from pathlib import Path

import pytest
import torch
from commands import run_command

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def motion_env():
    import gymnasium as gym

    import agile.tasks  # noqa: F401

    env = gym.make("MotionTracking-G1-v0", num_envs=2, device="cpu", seed=0)
    yield env.unwrapped
    env.close()


def test_the_reference_copy_stands_at_the_motions_stored_body_poses(motion_env, tmp_path):
    import imageio.v2 as imageio
    from agile.run.recorders import VideoRecorder

    env = motion_env
    path = tmp_path / "side_by_side.mp4"
    # env 1: its world and the reference both sit at an env origin that is not the world's origin
    video = VideoRecorder(str(path), env, 32, 24, env_index=1, reference=True)
    scene = video.reference
    term = env.command_manager.get_term("motion")
    env.reset()
    body_q_per_world = env.sim.model.body_count // env.num_envs
    for _ in range(3):
        env.step(torch.zeros(env.num_envs, env.action_manager.total_action_dim))
        video.record(env)
        frame = int(term.time_steps[1])
        drawn = torch.from_numpy(scene.state.body_q.numpy())
        reference = drawn[scene.reference_bodies]
        offset_m = scene.offset_m + env.env_origins[1]
        # the copy's bodies are in the robot's body order: the tracked ones and the root, as the motion file has them
        expected_pos_m = term.motion_body_pos[frame] + offset_m
        assert torch.allclose(reference[term.body_ids, :3], expected_pos_m, atol=1e-5)
        assert torch.allclose(reference[term.body_ids, 3:], term.motion_body_quat[frame], atol=1e-5)
        assert torch.allclose(reference[0, :3], term.motion_root_pose[0][frame] + offset_m, atol=1e-5)
        # the env's world is drawn as simulated
        simulated = torch.from_numpy(env.sim.state.body_q.numpy())[body_q_per_world:2 * body_q_per_world]
        assert torch.equal(drawn[:body_q_per_world], simulated)
    # the camera frames the robot and the copy: it follows their centre
    robot_root_m = env.scene["robot"].root_pos_w[1]
    assert torch.linalg.norm(robot_root_m[:2] - scene.reference_root_pos_w(env)[:2]) < 2.0
    video.close()
    frames = [f for f in imageio.get_reader(str(path))]  # list() trips on its infinite len()
    assert len(frames) == 3 and frames[0].shape == (24, 32, 3)


def test_a_task_without_a_reference_pose_has_no_reference_view(t1_env, tmp_path):
    from agile.run.recorders import VideoRecorder

    with pytest.raises(ValueError, match="reference pose"):
        VideoRecorder(str(tmp_path / "x.mp4"), t1_env, 32, 24, reference=True)


def test_play_writes_the_side_by_side_video(tmp_path):
    import imageio.v2 as imageio

    path = tmp_path / "play.mp4"
    args = ["--task", "MotionTracking-G1-v0", "--num_envs", "2", "--num_steps", "4", "--device", "cpu", "--sinusoidal",
            "--video", str(path), "--video_size", "64", "48", "--video_reference", "env.commands.motion.start_frame=0"]
    code, out, err = run_command("play", *args, cwd=ROOT)
    assert code == 0 and path.is_file(), out + err
    frames = [f for f in imageio.get_reader(str(path))]
    assert len(frames) == 4 and frames[0].shape == (48, 64, 3)
    assert frames[-1].std() > 5.0  # not blank
    # without --video there is nothing to draw into
    code, out, err = run_command("play", *args[:args.index("--video")], "--video_reference", cwd=ROOT)
    assert code == 2 and "--video_reference" in err
