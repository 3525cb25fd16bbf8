"""Export (TorchScript, ONNX, IO descriptor) and the plain-MuJoCo replay of an exported policy."""

import json
import sys
from pathlib import Path

import gymnasium as gym
import mujoco
import newton
import numpy as np
import pytest
import torch
import warp as wp
from rsl_rl.runners import OnPolicyRunner

import agile.tasks
from agile.assets.unitree_g1 import g1_robot_cfg
from agile.rl_env.rsl_rl import RslRlVecEnvWrapper, to_rsl_rl_dict
from agile.rl_env.rsl_rl.exporter import (example_input, export_policy, io_descriptor, read_io_descriptor,
                                          write_io_descriptor)
from agile.sim import SimCfg, Simulation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import sim2mujoco  # noqa: E402


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A randomly initialised G1 policy exported with its env's descriptor: (env, runner, folder)."""
    out = tmp_path_factory.mktemp("exported")
    env = gym.make("Velocity-G1-History-v0", num_envs=2, device="cpu").unwrapped
    _, agent_cfg = agile.tasks.load_cfgs("Velocity-G1-History-v0")
    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=None, device="cpu")
    export_policy(runner, str(out))
    write_io_descriptor(str(out / "io_descriptor.yaml"), io_descriptor(env, agent_cfg))
    return env, agent_cfg, runner, out


def test_exported_torchscript_and_onnx_match_the_training_policy(exported):
    from onnx.reference import ReferenceEvaluator

    env, agent_cfg, runner, out = exported
    obs = example_input(env, agent_cfg) + torch.randn(2, 1) * 0.1
    expected = runner.get_inference_policy()(
        {g: t for g, t in zip(agent_cfg.obs_groups["actor"], [obs])}).detach()
    jit = torch.jit.load(str(out / "policy.pt"))
    assert torch.allclose(jit(obs), expected, atol=1e-5)
    assert not (out / "policy.onnx.data").exists()  # one self-contained file
    onnx_model = ReferenceEvaluator(str(out / "policy.onnx"))
    for row in range(2):
        got = onnx_model.run(None, {onnx_model.input_names[0]: obs[row:row + 1].numpy()})[0]
        assert np.allclose(got, expected[row:row + 1].numpy(), atol=1e-5)


def test_io_descriptor_round_trips_and_describes_the_policy_input(exported):
    env, agent_cfg, _, out = exported
    descriptor = read_io_descriptor(str(out / "io_descriptor.yaml"))
    assert descriptor == io_descriptor(env, agent_cfg)
    terms = descriptor["observations"]["policy"]
    assert [t["name"] for t in terms][:3] == ["base_ang_vel", "projected_gravity", "velocity_commands"]
    assert sum(t["dim"] * max(t["history_length"], 1) for t in terms) == env.observation_manager.group_dims["policy"]
    assert len(descriptor["actions"][0]["joint_names"]) == 14 and descriptor["control_dt_s"] == pytest.approx(0.02)
    assert descriptor["actuators"]["legs"]["type"] == "DelayedDCMotorCfg"


def test_g1_feet_are_imported_as_colliders():
    builder_sim = Simulation(SimCfg(), g1_robot_cfg(), 1, "cpu", 0.02)
    model = builder_sim.model
    labels = [model.shape_label[i] for i in range(model.shape_count)
              if model.shape_flags.numpy()[i] & int(newton.ShapeFlags.COLLIDE_SHAPES)]
    assert sum("foot_box" in label for label in labels) == 2
    assert sum("foot1_collision" in label for label in labels) == 2


def test_newton_and_plain_mujoco_agree_on_the_same_torques(exported):
    _, _, _, out = exported
    descriptor = read_io_descriptor(str(out / "io_descriptor.yaml"))
    cfg = g1_robot_cfg()
    for group in cfg.actuators.values():
        group.max_delay = 0  # sim2mujoco does not model delays
    sim = Simulation(SimCfg(), cfg, 1, "cpu", 0.02)
    robot = sim.robot
    targets = robot.default_joint_pos[0].numpy() + np.random.default_rng(0).uniform(-0.3, 0.3, robot.num_joints)
    robot.joint_pos_target[0] = torch.tensor(targets, dtype=torch.float32)
    model = sim2mujoco.build_model(descriptor, sim2mujoco.default_mjcf(descriptor))
    data = mujoco.MjData(model)
    mj_robot = sim2mujoco.Robot(descriptor, model)
    data.qpos[2] = descriptor["default_root_height_m"]
    data.qpos[mj_robot.qpos_adr] = mj_robot.default_q
    mujoco.mj_forward(model, data)
    mj_robot.target = targets
    for _ in range(8):  # 40 ms with the feet touching down
        sim.step(1)
        data.qfrc_applied[mj_robot.dof_adr] = mj_robot.torque(data.qpos[mj_robot.qpos_adr], data.qvel[mj_robot.dof_adr])
        mujoco.mj_step(model, data)
    assert np.abs(robot.joint_pos[0].numpy() - data.qpos[mj_robot.qpos_adr]).max() < 2e-3
    assert abs(robot.root_pos_w[0, 2].item() - data.qpos[2]) < 2e-3


def test_sim2mujoco_runs_an_exported_policy(exported):
    _, _, _, out = exported
    descriptor = read_io_descriptor(str(out / "io_descriptor.yaml"))
    for policy in ("policy.pt", "policy.onnx"):
        metrics = sim2mujoco.run(descriptor, sim2mujoco.default_mjcf(descriptor), str(out / policy), episodes=1,
                                 duration_s=0.5, command=[0.3, 0.0, 0.0])
        assert metrics["episodes"] == 1 and 0 < metrics["mean_episode_length_s"] <= 0.5 + 1e-9
        assert np.isfinite(metrics["lin_vel_error_mps"]) and metrics["falls"] in (0, 1)


def test_sim2mujoco_renders_a_video_headless(exported, tmp_path):
    import imageio.v2 as imageio

    _, _, _, out = exported
    video_path, metrics_path = tmp_path / "mujoco.mp4", tmp_path / "metrics.json"
    sim2mujoco.main(["--io", str(out / "io_descriptor.yaml"), "--policy", str(out / "policy.pt"), "--episodes", "1",
                     "--duration_s", "0.3", "--command", "0.3", "0", "0", "--video", str(video_path),
                     "--out", str(metrics_path)])
    metrics = json.loads(metrics_path.read_text())
    frames = [frame for frame in imageio.get_reader(str(video_path))]  # list() trips on its infinite len()
    assert len(frames) == round(metrics["mean_episode_length_s"] / 0.02) and frames[0].shape == (480, 640, 3)
    # the robot's visual meshes (light grey) fill the middle of the frame; the ground and sky are dark
    centre = frames[-1][100:380, 220:420].astype(int)
    assert (centre.mean(axis=-1) > 120).sum() > 2000
