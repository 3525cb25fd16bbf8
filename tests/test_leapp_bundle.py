"""LEAPP bundles (`agile export --format leapp`): raw robot state in, the shipped policies' joint targets out, run by
LEAPP's own runtime (`leapp.InferenceManager`) in plain MuJoCo."""

import json
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml
from commands import run_command

import agile.tasks
from agile.rl.checkpoints import load_checkpoint
from agile.export.leapp_bundle import SUPPORTED_OBSERVATIONS, DeployGraph, UnsupportedPolicyError
from agile.deploy import mujoco_robot
from agile.run import sim2mujoco
from agile.run.env import build_env
from agile.run.export import export, export_leapp
from agile.run.mujoco_commands import make_commands
from agile.run.fingerprint import shipped_policies
from agile.run.policy import inference_cfg, load_runner
from agile.utils.config import apply_overrides

VELOCITY_POLICIES = ["Velocity-T1-v0", "Velocity-G1-History-v0", "Velocity-Height-G1-Teacher-v0",
                     "Velocity-Height-G1-Student-History-v0", "Velocity-Height-G1-Student-Recurrent-v0",
                     "Velocity-Go1-v0", "Velocity-Flat-Go1-v0"]
"""Every shipped velocity and velocity-height policy: what a robot runs from raw state."""


def test_every_shipped_velocity_policy_is_covered():
    shipped = {p.task for p in shipped_policies() if p.task.startswith("Velocity")}
    assert shipped == set(VELOCITY_POLICIES)


@pytest.fixture(scope="module", params=VELOCITY_POLICIES)
def exported(request, tmp_path_factory):
    """The shipped policy of a task exported both ways from one env: (TorchScript folder, bundle YAML)."""
    task = request.param
    (policy,) = [p for p in shipped_policies() if p.task == task]
    env_cfg, agent_cfg = agile.tasks.load_cfgs(task)
    env_cfg.num_envs = 1
    # flat ground: a bundle holds no terrain, and a rough one takes seconds to build on a CPU
    apply_overrides({"env": env_cfg, "agent": agent_cfg}, [*policy.overrides, "env.scene.terrain=null"])
    env = build_env(task, inference_cfg(env_cfg), "cpu")
    try:
        runner = load_runner(load_checkpoint(str(policy.file)), env, agent_cfg)
        out = tmp_path_factory.mktemp(task)
        paths = export(task, env, agent_cfg, runner, str(out / "torchscript"))
        bundle = export_leapp(env, agent_cfg, runner, str(out / "leapp"))["leapp"]
    finally:
        env.close()
    return paths, Path(bundle)


def test_the_bundle_gives_the_torchscript_policys_targets_on_the_same_states(exported):
    """The TorchScript policy (observations rebuilt from the IO descriptor) walks in MuJoCo; at every step the bundle,
    fed the same raw state, gives the same joint targets. An episode restart in the middle checks that the bundle's
    initial values restore its last action, histories and hidden state."""
    paths, bundle = exported
    descriptor = sim2mujoco.yaml_load(paths["io_descriptor"])
    model = mujoco_robot.build_model(descriptor, sim2mujoco.default_mjcf(descriptor))
    data = mujoco.MjData(model)
    walking, shadow = mujoco_robot.Robot(descriptor, model), mujoco_robot.Robot(descriptor, model)
    torchscript = sim2mujoco.DescriptorPolicy(descriptor, walking, paths["jit"])
    leapp_runtime = sim2mujoco.BundlePolicy(str(bundle), shadow)
    command = np.array([0.4, 0.0, 0.3, 0.7][:make_commands(
        next(iter(descriptor["commands"].values())), np.random.default_rng(0), descriptor["control_dt_s"]).dim])
    worst_rad = 0.0
    for episode_steps in (60, 40):
        mujoco.mj_resetData(model, data)
        data.qpos[2] = descriptor["default_root_height_m"]
        data.qpos[walking.qpos_adr] = walking.default_q
        mujoco.mj_forward(model, data)
        torchscript.reset()
        leapp_runtime.reset()
        for _ in range(episode_steps):
            torchscript(data, command)
            leapp_runtime(data, command)
            worst_rad = max(worst_rad, float(np.abs(walking.target - shadow.target).max()))
            for _ in range(descriptor["decimation"]):
                data.qfrc_applied[walking.dof_adr] = walking.torque(data.qpos[walking.qpos_adr],
                                                                    data.qvel[walking.dof_adr])
                mujoco.mj_step(model, data)
    assert worst_rad < 1e-4, f"bundle and TorchScript targets differ by up to {worst_rad:.2e} rad"
    assert data.qpos[2] > 0.5 * descriptor["default_root_height_m"], "the robot fell: the comparison saw no walking"


def test_the_bundles_onnx_sessions_run_on_one_thread_that_does_not_spin(exported):
    """ONNX Runtime's defaults (a pool of one thread per core, spinning between runs) keep a core busy between a
    deployed policy's runs (agile/deploy/leapp_runtime.py); the runtime's InferenceSessions are built without them."""
    from agile.deploy.leapp_runtime import BundleRuntime

    runtime = BundleRuntime(str(exported[1]))
    assert runtime.inference_sessions, "the bundle has no ONNX node: nothing was checked"
    for name, inference_session in runtime.inference_sessions.items():
        options = inference_session.get_session_options()
        assert options.intra_op_num_threads == 1, name
        assert options.get_session_config_entry("session.intra_op.allow_spinning") == "0", name


def test_deploy_gives_the_bundles_targets_from_the_io_descriptor_and_policy_onnx(exported):
    """`agile deploy --io --policy` (the descriptor's observation rules, policy.onnx in ONNX Runtime) and `agile
    deploy --bundle` give the same joint targets from the same robot states, histories and last action included."""
    from agile.deploy.policy import DeployPolicy, RobotState, quat_from_rpy
    from agile.deploy.robots import DeployError, ROBOTS, read_deploy_bundle, read_deploy_descriptor

    paths, bundle = exported
    robot_file = yaml.safe_load(bundle.read_text())["pipeline"]["configs"]["robot"]["robot_model_file"]
    robot = next((r for r in ROBOTS.values() if robot_file in r.model_files), None)
    if robot is None:
        # agile deploy drives the G1 and the T1: another robot's policy is refused both ways, naming its robot file
        for other in ROBOTS.values():
            with pytest.raises(DeployError, match=f"for robot file '{re.escape(robot_file)}'"):
                read_deploy_bundle(str(bundle), other)
            with pytest.raises(DeployError, match=f"for robot file '{re.escape(robot_file)}'"):
                read_deploy_descriptor(paths["io_descriptor"], paths["onnx"], other)
        return
    try:
        from_bundle = DeployPolicy(read_deploy_bundle(str(bundle), robot), robot)
    except DeployError as err:
        assert "root_lin_vel_b" in str(err)  # a policy that reads the base velocity is refused both ways
        with pytest.raises(DeployError, match="root_lin_vel_b"):
            read_deploy_descriptor(paths["io_descriptor"], paths["onnx"], robot)
        return
    from_descriptor = DeployPolicy(read_deploy_descriptor(paths["io_descriptor"], paths["onnx"], robot), robot)
    rng = np.random.default_rng(0)
    n = len(robot.motor_joints)
    command = np.array([0.4, 0.0, 0.3, 0.7][:len(from_bundle.runtime.inputs["command"]["element_names"][-1])])
    worst_rad = 0.0
    for episode_steps in (30, 20):
        from_bundle.reset()
        from_descriptor.reset()
        for step in range(episode_steps):
            state = RobotState(q=from_bundle.default_q + rng.normal(0, 0.1, n), dq=rng.normal(0, 0.5, n),
                               tau=np.zeros(n), quat_wxyz=quat_from_rpy(*rng.normal(0, 0.1, 3)),
                               gyro_radps=rng.normal(0, 0.3, 3), tick=step, received_s=0.0)
            q_bundle, _, _ = from_bundle(state, command)
            q_descriptor, _, _ = from_descriptor(state, command)
            worst_rad = max(worst_rad, float(np.abs(q_bundle - q_descriptor).max()))
    assert worst_rad < 1e-4, f"descriptor and bundle targets differ by up to {worst_rad:.2e} rad"


def test_the_bundle_names_what_a_deployer_wires(exported):
    paths, bundle = exported
    task = bundle.stem
    assert sorted(p.name for p in bundle.parent.iterdir()) == sorted(
        [f"{task}.yaml", f"{task}.onnx", f"{task}_initial_values.safetensors"])
    spec = yaml.safe_load(bundle.read_text())
    descriptor = sim2mujoco.yaml_load(paths["io_descriptor"])
    node = spec["models"][task]
    inputs = {i["name"]: i for i in node["inputs"]}
    external = spec["pipeline"]["inputs"][task]
    assert "joint_pos" in external and "command" in external
    for name in external:
        assert inputs[name]["kind"].startswith(("state/", "command/")), inputs[name]
        assert inputs[name]["isaaclab_connection"].split(":")[0] in ("state", "command"), inputs[name]
    assert inputs["joint_pos"]["element_names"] == [descriptor["joint_names"]]
    outputs = {o["name"]: o for o in node["outputs"]}
    action_joints = [n for a in descriptor["actions"] for n in a["joint_names"]]
    target = outputs["joint_pos_target"]
    assert target["kind"] == "target/joint/position" and target["element_names"] == [action_joints]
    assert outputs["joint_pos_kp_gains"]["kind"] == "kp" and outputs["joint_pos_kd_gains"]["kind"] == "kd"
    feedback = spec["pipeline"]["feedback_flow"]
    assert feedback[f"{task}/last_action_out"] == [f"{task}/last_action_in"]
    configs = spec["pipeline"]["configs"]
    assert configs["frequency"] == pytest.approx(1.0 / descriptor["control_dt_s"])
    assert configs["robot"]["default_joint_pos"] == descriptor["default_joint_pos"]
    assert configs["robot"]["stiffness"] == descriptor["stiffness"]


def test_sim2mujoco_runs_a_bundle_from_the_command_line(exported, tmp_path):
    _, bundle = exported
    out = tmp_path / "metrics.json"
    code, stdout, stderr = run_command("sim2mujoco", "--bundle", bundle, "--episodes", "1", "--duration_s", "1.0",
                                       "--out", out)
    assert code == 0, stdout + stderr
    metrics = json.loads(out.read_text())
    assert metrics["episodes"] == 1 and metrics["falls"] == 0 and metrics["bundle"] == str(bundle)
    assert "WARNING" not in stdout + stderr  # LEAPP's runtime warnings stay quiet


def test_the_policy_walks_forward_in_plain_mujoco_without_falling(exported):
    """0.5 m/s forward for a second from the default pose in MuJoCo C with its own solver iterations. With training's
    cap (10, 20) the Go1's contacts blew up within 0.12 s (3 of 3 episodes, the rough policy at iteration 2,800)."""
    paths, _ = exported
    descriptor = sim2mujoco.yaml_load(paths["io_descriptor"])
    spec = next(iter(descriptor["commands"].values()))
    walking_height_m = [spec["params"]["default_height_m"]] if "base_height_m" in spec["ranges"] else []
    metrics = sim2mujoco.run(descriptor, sim2mujoco.default_mjcf(descriptor),
                             lambda robot: sim2mujoco.DescriptorPolicy(descriptor, robot, paths["jit"]),
                             episodes=1, duration_s=1.0, command=[0.5, 0.0, 0.0, *walking_height_m])
    assert metrics["falls"] == 0 and metrics["mean_episode_length_s"] == pytest.approx(1.0), metrics


def test_a_policy_that_reads_more_than_raw_robot_state_is_refused_naming_the_term(exported):
    paths, _ = exported
    descriptor = sim2mujoco.yaml_load(paths["io_descriptor"])
    group = descriptor["observation_groups"][0]
    descriptor["observations"][group][0] = {**descriptor["observations"][group][0], "name": "terrain",
                                            "func": "height_scan"}
    with pytest.raises(UnsupportedPolicyError, match="terrain \\(height_scan\\)") as error:
        DeployGraph(descriptor, actor=None)
    assert str(SUPPORTED_OBSERVATIONS) in str(error.value)


def test_sim2mujoco_wants_a_bundle_or_a_descriptor_and_policy(tmp_path):
    (tmp_path / "io.yaml").write_text("version: 2\n")
    code, stdout, stderr = run_command("sim2mujoco", "--io", tmp_path / "io.yaml")
    assert code == 2 and "give either --bundle, or --io and --policy" in stdout + stderr
