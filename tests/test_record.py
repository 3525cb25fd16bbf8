"""agile record: demonstrations of PickPlace-G1-Record-v0 written as a GR00T LeRobot dataset (CPU, small camera)."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from commands import run_command

ROOT = Path(__file__).resolve().parents[1]
TASK = "PickPlace-G1-Record-v0"
SMALL_CAMERA = ["env.scene.cameras.front_cam.width=64", "env.scene.cameras.front_cam.height=48"]
EPISODE_STEPS = 15
LEROBOT_PYTHON = os.environ.get("AGILE_LEROBOT_PYTHON")
"""An interpreter with `lerobot-dataset`, torchvision and torchcodec (scripts/check_lerobot_dataset.py says why it
cannot be this one); CI's CPU torch has no torchvision build, so the reader check runs where this is set."""


def gradient(value: int, height: int = 48, width: int = 64) -> np.ndarray:
    """A smooth test image (H.264 keeps it within a few levels) whose brightness tells the frames apart."""
    y, x = np.mgrid[0:height, 0:width]
    image = np.stack([x * 3, y * 4, np.full_like(x, value)], axis=-1) + value // 2
    return np.clip(image, 0, 255).astype(np.uint8)


def decode(path: Path) -> list[np.ndarray]:
    import av

    with av.open(str(path)) as container:
        return [frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)]


def read_rows(dataset: Path, episode: int) -> dict:
    import pyarrow.parquet as pq

    return pq.read_table(dataset / f"data/chunk-000/episode_{episode:06d}.parquet").to_pydict()


@pytest.mark.parametrize("encode_processes", [0, 2], ids=["inline", "two_processes"])
def test_the_writer_makes_each_ended_episode_its_own_and_drops_the_unfinished(tmp_path, encode_processes):
    from agile.run.lerobot_dataset import LeRobotDatasetWriter, Slices

    root = tmp_path / "demos"
    writer = LeRobotDatasetWriter(root, fps=50, task_description="pick the cube", robot_type="g1",
                                  state=Slices([("a", 2), ("b", 1)], ["a0", "a1", "b0"]),
                                  action=Slices([("arm", 2)], ["j0", "j1"]), video_shapes={"image": (48, 64)},
                                  streams=2, encode_processes=encode_processes)
    images = {0: [], 1: []}
    # stream 1 ends early (3 frames), stream 0 times out (5 frames), stream 1's next episode is cut by the stop
    for step in range(5):
        for stream in (0, 1):
            if stream == 1 and step == 4:
                continue
            image = gradient(40 * step + 20 * stream)
            done = (stream == 0 and step == 4) or (stream == 1 and step == 2)
            writer.add_frame(stream, np.full(3, step + 10 * stream, np.float32), np.full(2, -step, np.float32),
                             reward=0.5, done=done, images={"image": image})
            images[stream].append(image)
            if done:
                assert writer.end_episode(stream) == (0 if stream == 1 else 1)
    writer.close()
    assert not (root / ".in_progress").exists()
    meta = root / "meta"
    assert [json.loads(line)["length"] for line in (meta / "episodes.jsonl").read_text().splitlines()] == [3, 5]
    info = json.loads((meta / "info.json").read_text())
    assert (info["total_frames"], info["total_episodes"], info["total_videos"], info["fps"]) == (8, 2, 2, 50)
    assert info["features"]["observation.images.image"]["shape"] == [48, 64, 3]
    modality = json.loads((meta / "modality.json").read_text())
    assert modality["state"] == {"a": {"start": 0, "end": 2}, "b": {"start": 2, "end": 3}}
    assert modality["video"] == {"image": {"original_key": "observation.images.image"}}
    for episode, stream, first_index in ((0, 1, 0), (1, 0, 3)):
        rows = read_rows(root, episode)
        length = len(rows["index"])
        assert rows["index"] == list(range(first_index, first_index + length))  # global, contiguous
        assert rows["episode_index"] == [episode] * length and rows["frame_index"] == list(range(length))
        assert rows["timestamp"] == pytest.approx([i / 50 for i in range(length)], abs=1e-7)
        assert rows["next.done"] == [False] * (length - 1) + [True]
        assert rows["observation.state"][0] == [10.0 * stream] * 3
        frames = decode(root / f"videos/chunk-000/observation.images.image/episode_{episode:06d}.mp4")
        assert len(frames) == length
        for frame, image in zip(frames, images[stream]):
            assert np.abs(frame.astype(float) - image).mean() < 3.0  # each frame is its own row's image
    stats = [json.loads(line) for line in (meta / "episodes_stats.jsonl").read_text().splitlines()]
    assert np.asarray(stats[0]["stats"]["observation.images.image"]["mean"]).shape == (3, 1, 1)
    assert stats[1]["stats"]["observation.state"]["count"] == [5]
    assert set(json.loads((meta / "stats.json").read_text())["action"]) == {"mean", "std", "min", "max", "q01", "q99"}


def test_a_failing_encoder_process_is_reported_with_its_error(tmp_path):
    from agile.run.video_encoders import ProcessEncoders

    encoders = ProcessEncoders(fps=50, processes=1)
    image = gradient(10)
    encoders.frame(0, tmp_path / "missing_folder" / "a.mp4", image, 0)  # the worker cannot create this file
    with pytest.raises(RuntimeError, match="video encod.*missing_folder"):
        for index in range(1, 200):  # the pipe breaks once the worker has stopped
            encoders.frame(0, tmp_path / "missing_folder" / "a.mp4", image, index)
        encoders.close()


def test_the_writer_refuses_an_existing_folder_and_odd_video_sizes(tmp_path):
    from agile.run.lerobot_dataset import LeRobotDatasetWriter, Slices

    kwargs = dict(fps=50, task_description="t", robot_type="r", state=Slices([("a", 1)], ["a"]),
                  action=Slices([("b", 1)], ["b"]), streams=1)
    with pytest.raises(ValueError, match="even sizes"):
        LeRobotDatasetWriter(tmp_path / "odd", video_shapes={"image": (47, 64)}, **kwargs)
    with pytest.raises(FileExistsError):
        LeRobotDatasetWriter(tmp_path, video_shapes={"image": (48, 64)}, **kwargs)


@pytest.fixture(scope="module")
def record_env():
    """The recording task with a small camera, 2 envs on CPU (one build for the tests below)."""
    import gymnasium as gym

    import agile.tasks  # noqa: F401  (registers the tasks)

    env = gym.make(TASK, num_envs=2, device="cpu", overrides=SMALL_CAMERA).unwrapped
    yield env
    env.close()


@pytest.fixture(scope="module")
def checkpoint(record_env, tmp_path_factory):
    """An untrained PickPlace policy's checkpoint (the task ships none yet): the recording is the point here."""
    from rsl_rl.runners import OnPolicyRunner

    import agile.tasks
    from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict

    _, agent_cfg = agile.tasks.load_cfgs("PickPlace-G1-v0")  # the recording task runs PickPlace's policy
    runner = OnPolicyRunner(RslRlVecEnvWrapper(record_env), to_rsl_rl_dict(agent_cfg), log_dir=None, device="cpu")
    path = tmp_path_factory.mktemp("policy") / "model.pt"
    runner.save(str(path))
    return path


@pytest.fixture(scope="module")
def dataset(checkpoint, tmp_path_factory):
    out = tmp_path_factory.mktemp("record") / "demos"
    code, stdout, stderr = run_command(
        "record", "--task", TASK, "--device", "cpu", "--num_envs", "3", "--num_episodes", "4", "--out", out,
        "--checkpoint", checkpoint, "--encode_processes", "2", *SMALL_CAMERA, f"env.episode_length_s={EPISODE_STEPS * 0.02}", cwd=ROOT)
    assert code == 0, stdout[-2000:] + stderr[-2000:]
    assert "episode 4/4 written" in stdout and "frames/s" in stdout and "encoded in 2 processes" in stdout
    return out


def test_record_writes_pick_and_place_episodes_with_camera_state_and_action(dataset):
    info = json.loads((dataset / "meta/info.json").read_text())
    assert info["fps"] == 50 and info["total_episodes"] == 4 and info["total_frames"] == 4 * EPISODE_STEPS
    state_names = info["features"]["observation.state"]["names"]
    assert len(state_names) == 45 and "joint_pos.right_elbow_joint" in state_names
    action_names = info["features"]["action"]["names"]
    assert len(action_names) == 21 and action_names[-4:] == [
        "lower_body_joint_pos.lin_vel_x", "lower_body_joint_pos.lin_vel_y", "lower_body_joint_pos.ang_vel_z",
        "lower_body_joint_pos.base_height_m"]
    modality = json.loads((dataset / "meta/modality.json").read_text())
    assert modality["state"]["base_ang_vel"] == {"start": 0, "end": 3}  # AGILE's slices, then the object pose
    assert modality["state"]["joint_vel"] == {"start": 23, "end": 38}
    assert modality["state"]["object_pose"] == {"start": 38, "end": 45}
    for episode in range(4):
        rows = read_rows(dataset, episode)
        frames = decode(dataset / f"videos/chunk-000/observation.images.image/episode_{episode:06d}.mp4")
        assert len(frames) == len(rows["index"]) == EPISODE_STEPS and frames[0].shape == (48, 64, 3)
        assert rows["next.done"][-1] and not any(rows["next.done"][:-1])
        object_z = np.asarray(rows["observation.state"])[:, 40]
        assert np.all((object_z > 0.6) & (object_z < 1.0))  # the cube, on the table, in the env frame
        targets = np.asarray(rows["action"])[:, :17]
        assert np.abs(targets).max() < 3.2  # absolute joint targets [rad], not raw policy outputs
    assert frames[0].std() > 5.0  # the camera sees the scene, not a blank frame


def test_each_episode_draws_its_props_colours_and_its_first_frame_shows_them(record_env):
    import torch

    from agile.run.record import randomise_colors, rerender

    env = record_env
    obs, _ = env.reset()
    camera = env.scene["front_cam"]
    before = obs["record"]["image"].clone()
    table = env.scene["table"]
    black = torch.zeros(2, 3)
    table.set_color(black, torch.tensor([True, False]))  # env 0's table black, env 1's as it was
    assert torch.all(torch.as_tensor(env.sim.model.shape_color.numpy())[table.shape_ids[0]] == 0.0)
    camera.mark_stale()
    after = camera.rgb(env.sim.state).float()
    assert after[0].mean() < before[0].float().mean() - 10.0  # the table fills much of the view
    assert torch.equal(after[1], before[1].float())
    # a palette of one colour per prop: every env gets it, and the observation's frame shows it
    palettes = {"table": ((1.0, 1.0, 1.0),), "object": ((0.0, 1.0, 0.0),)}
    randomise_colors(env, palettes, torch.Generator().manual_seed(0), torch.ones(2, dtype=torch.bool))
    rerender(env, obs, {"image": "front_cam"})
    assert obs["record"]["image"][0].float().mean() > after[0].mean() + 10.0
    colors = torch.as_tensor(env.sim.model.shape_color.numpy())
    assert torch.all(colors[env.scene["object"].shape_ids] == torch.tensor([0.0, 1.0, 0.0]))
    with pytest.raises(ValueError, match="color_rgb of shape"):
        table.set_color(torch.zeros(3), torch.ones(2, dtype=torch.bool))


def test_record_refuses_bad_input_in_one_line(tmp_path, checkpoint):
    code, _, err = run_command("record", "--task", TASK, "--num_episodes", "1", "--out", tmp_path, cwd=ROOT)
    assert code == 2 and "exists" in err and len(err.strip().splitlines()) == 1
    code, _, err = run_command("record", "--task", "Velocity-T1-v0", "--num_episodes", "1", "--out",
                               tmp_path / "new", cwd=ROOT)
    assert code == 2 and f"recording tasks: {TASK}" in err
    shipped_t1 = ROOT / "agile/data/policy/Velocity-T1-v0.pt"
    code, _, err = run_command("record", "--task", TASK, "--device", "cpu", "--num_envs", "1", "--num_episodes", "1",
                               "--out", tmp_path / "new", "--checkpoint", shipped_t1, *SMALL_CAMERA, cwd=ROOT)
    assert code == 2 and "a policy of another task?" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "new").exists()


@pytest.mark.skipif(LEROBOT_PYTHON is None, reason="set AGILE_LEROBOT_PYTHON to an interpreter with lerobot-dataset, "
                    "torchvision and torchcodec (see scripts/check_lerobot_dataset.py)")
def test_lerobots_own_reader_loads_the_recording(dataset):
    # another interpreter is the point: LeRobot's reader needs a torch with torchvision, which this one lacks
    result = subprocess.run([LEROBOT_PYTHON, str(ROOT / "scripts/check_lerobot_dataset.py"), str(dataset)],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    report = json.loads(result.stdout.strip().splitlines()[-1])
    assert report["frames"] == 4 * EPISODE_STEPS and all(report["checks"].values())
