"""Export (TorchScript, ONNX, IO descriptor) and the plain-MuJoCo replay of an exported policy."""

import json
from pathlib import Path

import gymnasium as gym
import mujoco
import newton
import numpy as np
import pytest
import torch
from rsl_rl.runners import OnPolicyRunner

import agile.tasks
from agile.assets.unitree_g1 import g1_robot_cfg
from agile.rl import RslRlVecEnvWrapper, make_recurrent, to_rsl_rl_dict
from agile.export.io_descriptor import io_descriptor
from agile.export.policy_files import example_input, export_policy
from agile.rl_env.io_descriptor_file import read_io_descriptor, write_io_descriptor
from commands import FLAT_GROUND, run_command
from scenes import robot_sim

from agile.deploy import mujoco_robot
from agile.run import sim2mujoco  # noqa: E402


TASK = "Velocity-G1-History-v0"


def export_random_policy(env, agent_cfg, out: Path) -> OnPolicyRunner:
    """A randomly initialised runner for `agent_cfg`, its actor exported into `out` with the env's descriptor."""
    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=None, device="cpu")
    # normaliser statistics away from (0, 1), so that the export has something to fold in
    groups = agent_cfg.obs_groups["actor"]
    samples = {g: torch.randn(64, env.observation_manager.group_dims[g]) * 2.0 + 0.5 for g in groups}
    runner.alg.get_policy().update_normalization(samples)
    export_policy(runner, str(out))
    write_io_descriptor(str(out / "io_descriptor.yaml"), io_descriptor(env, agent_cfg))
    return runner


def actor_input(agent_cfg, obs: torch.Tensor) -> dict:
    """The training actor's input for the exported models' input (one actor observation group)."""
    (group,) = agent_cfg.obs_groups["actor"]
    return {group: obs}


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A randomly initialised G1 policy exported with its env's descriptor: (env, agent cfg, runner, folder)."""
    out = tmp_path_factory.mktemp("exported")
    env = gym.make(TASK, num_envs=2, device="cpu").unwrapped
    _, agent_cfg = agile.tasks.load_cfgs(TASK)
    return env, agent_cfg, export_random_policy(env, agent_cfg, out), out


@pytest.fixture(scope="module", params=[("lstm", 2), ("gru", 1)], ids=["lstm", "gru"])
def recurrent_exported(request, exported, tmp_path_factory):
    """As `exported` (same env), with a recurrent actor and critic of (rnn type, layers), 32 hidden units."""
    rnn_type, rnn_num_layers = request.param
    env = exported[0]
    out = tmp_path_factory.mktemp(f"exported_{rnn_type}")
    _, agent_cfg = agile.tasks.load_cfgs(TASK)
    make_recurrent(agent_cfg, rnn_type=rnn_type, rnn_hidden_dim=32, rnn_num_layers=rnn_num_layers)
    return env, agent_cfg, export_random_policy(env, agent_cfg, out), out


def test_exported_torchscript_and_onnx_match_the_training_policy(exported):
    from onnx.reference import ReferenceEvaluator

    env, agent_cfg, runner, out = exported
    obs = example_input(env, agent_cfg) + torch.randn(2, 1) * 0.1
    expected = runner.get_inference_policy()(actor_input(agent_cfg, obs)).detach()
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
    assert descriptor["policy"] == {"input": "obs", "output": "actions", "recurrent": False}


def test_recurrent_torchscript_and_onnx_match_the_training_policy_step_by_step(recurrent_exported):
    import onnxruntime
    from onnx.reference import ReferenceEvaluator

    env, agent_cfg, runner, out = recurrent_exported
    interface = read_io_descriptor(str(out / "io_descriptor.yaml"))["policy"]
    steps = 6
    obs = example_input(env, agent_cfg)[:1] + torch.randn(steps, 1, 1) * 0.3  # (steps, batch 1, obs_dim)
    training = runner.get_inference_policy()
    training.reset()  # zero hidden state; each call below carries it to the next
    expected = torch.stack([training(actor_input(agent_cfg, o)).detach()[0] for o in obs]).numpy()
    training.reset()
    assert not np.allclose(training(actor_input(agent_cfg, obs[1])).detach()[0], expected[1], atol=1e-4), \
        "the second action should depend on the hidden state left by the first step"
    # sim2mujoco's stepping: TorchScript keeps the hidden state inside, ONNX gets it fed back by descriptor names
    policies = {"torchscript": sim2mujoco.TorchScriptPolicy(str(out / "policy.pt")),
                "onnx reference": sim2mujoco.OnnxPolicy(ReferenceEvaluator(str(out / "policy.onnx")), interface),
                "onnxruntime": sim2mujoco.OnnxPolicy(onnxruntime.InferenceSession(str(out / "policy.onnx")),
                                                     interface)}
    for name, policy in policies.items():
        for when in ("fresh", "after reset()"):
            actions = np.stack([policy(o[0].numpy()) for o in obs])
            assert np.allclose(actions, expected, atol=1e-5), f"{name}, {when}"
            policy.reset()


def test_recurrent_io_descriptor_round_trips_and_names_the_hidden_state(recurrent_exported):
    import onnx

    env, agent_cfg, _, out = recurrent_exported
    descriptor = read_io_descriptor(str(out / "io_descriptor.yaml"))
    assert descriptor == io_descriptor(env, agent_cfg)
    interface = descriptor["policy"]
    actor = agent_cfg.actor
    assert interface["recurrent"] and interface["rnn_type"] == actor.rnn_type
    assert interface["rnn_hidden_dim"] == 32 and interface["rnn_num_layers"] == actor.rnn_num_layers
    assert len(interface["hidden_state"]) == {"lstm": 2, "gru": 1}[actor.rnn_type]  # LSTM: hidden and cell state
    # the names and shapes are those of the ONNX file's inputs and outputs
    graph = onnx.load(str(out / "policy.onnx")).graph

    def shapes(values) -> dict:
        return {v.name: [d.dim_value for d in v.type.tensor_type.shape.dim] for v in values}

    obs_dim, action_dim = env.observation_manager.group_dims["policy"], env.action_manager.total_action_dim
    hidden = interface["hidden_state"]
    assert shapes(graph.input) == {interface["input"]: [1, obs_dim], **{h["input"]: h["shape"] for h in hidden}}
    assert shapes(graph.output) == {interface["output"]: [1, action_dim], **{h["output"]: h["shape"] for h in hidden}}


def test_g1_feet_are_imported_as_colliders():
    builder_sim = robot_sim(g1_robot_cfg(), 1)
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
    sim = robot_sim(cfg, 1)
    robot = sim.scene["robot"]
    targets = robot.default_joint_pos[0].numpy() + np.random.default_rng(0).uniform(-0.3, 0.3, robot.num_joints)
    robot.joint_pos_target[0] = torch.tensor(targets, dtype=torch.float32)
    model = mujoco_robot.build_model(descriptor, sim2mujoco.default_mjcf(descriptor), solver="training")
    data = mujoco.MjData(model)
    mj_robot = mujoco_robot.Robot(descriptor, model)
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


def test_plain_mujoco_keeps_its_own_solver_iterations_unless_asked_for_trainings(exported, tmp_path):
    _, _, _, out = exported
    descriptor = read_io_descriptor(str(out / "io_descriptor.yaml"))
    mjcf = sim2mujoco.default_mjcf(descriptor)
    defaults = mujoco.MjModel.from_xml_string("<mujoco/>").opt
    model = mujoco_robot.build_model(descriptor, mjcf)
    assert (model.opt.iterations, model.opt.ls_iterations) == (defaults.iterations, defaults.ls_iterations)
    trained = mujoco_robot.build_model(descriptor, mjcf, solver="training")
    assert (trained.opt.iterations, trained.opt.ls_iterations) == (descriptor["solver"]["iterations"],
                                                                   descriptor["solver"]["ls_iterations"])
    assert trained.opt.iterations < defaults.iterations
    with pytest.raises(ValueError, match="solver must be one of mujoco, training, got 'newton'"):
        mujoco_robot.build_model(descriptor, mjcf, solver="newton")
    code, stdout, stderr = run_command("sim2mujoco", "--io", out / "io_descriptor.yaml", "--policy",
                                       out / "policy.pt", "--solver", "newton")
    assert code == 2 and "--solver" in stderr and "'mujoco', 'training'" in stderr, stdout + stderr


def check_sim2mujoco_runs(out: Path, episodes: int = 1) -> None:
    descriptor = read_io_descriptor(str(out / "io_descriptor.yaml"))
    for policy in ("policy.pt", "policy.onnx"):
        metrics = sim2mujoco.run(descriptor, sim2mujoco.default_mjcf(descriptor),
                                 lambda robot: sim2mujoco.DescriptorPolicy(descriptor, robot, str(out / policy)),
                                 episodes=episodes, duration_s=0.5, command=[0.3, 0.0, 0.0])
        assert metrics["episodes"] == episodes and 0 < metrics["mean_episode_length_s"] <= 0.5 + 1e-9
        assert np.isfinite(metrics["lin_vel_error_mps"]) and 0 <= metrics["falls"] <= episodes


def test_sim2mujoco_runs_an_exported_policy(exported):
    check_sim2mujoco_runs(exported[-1])


def test_sim2mujoco_runs_a_recurrent_policy(recurrent_exported):
    check_sim2mujoco_runs(recurrent_exported[-1], episodes=2)  # with a reset of the hidden state in between


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


def test_each_action_term_describes_itself_and_sim2mujoco_refuses_what_is_not_joint_targets(tmp_path, capsys):
    """Pick-and-place exports (its delta upper-body action and frozen lower body described by their own terms,
    not as joint targets), and sim2mujoco names the terms it cannot run instead of failing on a missing key."""
    env = gym.make("PickPlace-G1-v0", num_envs=2, device="cpu").unwrapped
    _, agent_cfg = agile.tasks.load_cfgs("PickPlace-G1-v0")
    actions = {a["name"]: a for a in io_descriptor(env, agent_cfg)["actions"]}
    delta, frozen = actions["upper_body_joint_pos"], actions["lower_body_joint_pos"]
    assert delta["type"] == "DeltaJointPositionAction" and "offset" not in delta
    assert len(delta["joint_names"]) == len(delta["scale_rad_per_step"]) == env.action_manager.get_term(
        "upper_body_joint_pos").action_dim
    assert frozen["type"] == "FrozenPolicyAction" and len(frozen["command_low"]) == 4
    descriptor_file = tmp_path / "io_descriptor.yaml"
    write_io_descriptor(str(descriptor_file), io_descriptor(env, agent_cfg))
    with pytest.raises(SystemExit):
        sim2mujoco.main(["--io", str(descriptor_file), "--policy", str(tmp_path / "policy.pt")])
    assert "upper_body_joint_pos (DeltaJointPositionAction)" in capsys.readouterr().err
    env.close()


@pytest.mark.parametrize("task", ["Velocity-T1-v0", "Velocity-G1-Teacher-v0"])
def test_the_io_descriptor_carries_the_envs_action_clamp(task):
    """The deployment clamps the raw policy output as the env does (`clip_actions`, read from the IO descriptor): the
    last-action observation in MuJoCo holds what the policy saw in training."""
    env = gym.make(task, num_envs=1, device="cpu", overrides=FLAT_GROUND).unwrapped
    _, agent_cfg = agile.tasks.load_cfgs(task)
    assert io_descriptor(env, agent_cfg)["clip_actions"] == env.cfg.clip_actions == env.action_manager.clip_actions
    env.close()
