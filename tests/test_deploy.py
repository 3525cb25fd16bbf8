"""agile deploy's parts without a real-time loop: the state machine's transitions and faults, each mode's command,
the bundle and input checks of the command line (one line, exit 2, before DDS starts), the T1's
conversion up to the SDK call, and the simulator's motor drivers. The loop against the DDS simulator:
tests/test_deploy_realtime.py (-m realtime); the commands and the G1 remote: tests/test_deploy_commands.py."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from deploy_fakes import N, FakeLink, controller, machine, state

from agile.deploy.policy import quat_from_rpy
from agile.deploy.robots import ROBOTS, DeployError, read_deploy_bundle
from agile.deploy.safety import Mode

REPO = Path(__file__).resolve().parents[1]
T1_BUNDLE = REPO / "docs/results/leapp/Velocity-T1-v0.yaml"
G1_BUNDLE_YAML = REPO / "docs/results/leapp/Velocity-Height-G1-Student-Recurrent-v0.yaml"


def test_start_signals_walk_the_modes_in_order_and_damping_is_final():
    m = machine()
    s = state()
    m.start("key", 0.0, None)  # no state yet: nothing moves
    assert m.mode is Mode.PASSIVE
    m.start("key", 0.0, s)
    assert m.mode is Mode.MOVE_TO_DEFAULT
    m.advance(1.9, s)
    assert m.mode is Mode.MOVE_TO_DEFAULT
    m.start("key", 1.9, s)  # a start during the move is ignored
    assert m.mode is Mode.MOVE_TO_DEFAULT
    m.advance(2.0, s)
    assert m.mode is Mode.HOLD
    m.advance(10.0, s)  # without autostart the hold waits for a start
    assert m.mode is Mode.HOLD
    m.start("key", 10.0, s)
    assert m.mode is Mode.POLICY
    m.stop("select", 11.0, s)
    assert m.mode is Mode.DAMPING and m.fault is None
    m.start("key", 12.0, s)
    m.go(Mode.POLICY, "anything", 12.0, s)
    assert m.mode is Mode.DAMPING
    assert [(t.source, t.target) for t in m.transitions] == [
        (Mode.PASSIVE, Mode.MOVE_TO_DEFAULT), (Mode.MOVE_TO_DEFAULT, Mode.HOLD), (Mode.HOLD, Mode.POLICY),
        (Mode.POLICY, Mode.DAMPING)]
    assert [t.cause for t in m.transitions] == ["key", "default pose reached after 2.0 s", "key", "select"]


def test_autostart_moves_holds_then_starts_the_policy():
    m = machine(autostart=True)
    m.advance(0.0, None)
    assert m.mode is Mode.PASSIVE
    m.advance(0.0, state())
    m.advance(2.0, state(2.0))
    m.advance(2.9, state(2.9))
    assert m.mode is Mode.HOLD
    m.advance(3.0, state(3.0))
    assert m.mode is Mode.POLICY


@pytest.mark.parametrize("mode", [Mode.PASSIVE, Mode.MOVE_TO_DEFAULT, Mode.HOLD, Mode.POLICY])
def test_a_stop_from_every_mode_damps(mode):
    m = machine()
    m.mode = mode
    m.stop("SIGINT (Ctrl-C)", 1.0, state(1.0))
    assert m.mode is Mode.DAMPING and m.transitions[-1].cause == "SIGINT (Ctrl-C)"


def test_link_lost_no_state_and_an_old_state():
    m = machine()
    m.check_state(0.05, None, started_s=0.0)
    assert m.mode is Mode.PASSIVE
    m.check_state(0.07, None, started_s=0.0)
    assert m.mode is Mode.DAMPING and "link lost" in m.fault
    m = machine()
    m.check_state(0.06, state(0.0), started_s=0.0)
    assert m.mode is Mode.PASSIVE
    m.check_state(0.061, state(0.0), started_s=0.0)
    assert m.mode is Mode.DAMPING and "link lost" in m.fault


def test_a_frozen_tick_damps_though_messages_keep_coming():
    m = machine()
    for i in range(20):  # 5 ms apart, always fresh, the same tick
        m.check_state(i * 0.005, state(i * 0.005, tick=7), started_s=0.0)
    assert m.mode is Mode.DAMPING and "frozen" in m.fault
    m = machine()
    for i in range(30):  # the tick moving: no fault
        m.check_state(i * 0.005, state(i * 0.005, tick=i), started_s=0.0)
    assert m.mode is Mode.PASSIVE


def test_a_fall_damps_from_hold_on_not_while_passive():
    tilted = quat_from_rpy(math.radians(50), 0.0, 0.0)
    m = machine()
    m.check_state(0.0, state(quat=tilted), started_s=0.0)
    assert m.mode is Mode.PASSIVE  # a robot on its gantry or being lifted is not falling
    m.mode = Mode.HOLD
    m.check_state(0.0, state(quat=quat_from_rpy(math.radians(40), 0.0, 0.0)), started_s=0.0)
    assert m.mode is Mode.HOLD
    m.check_state(0.0, state(quat=tilted), started_s=0.0)
    assert m.mode is Mode.DAMPING and "a fall" in m.fault


def test_a_joint_past_its_limits_damps_in_the_policy():
    m = machine()
    m.mode = Mode.POLICY
    q = np.zeros(N)
    q[3] = 1.09
    m.check_state(0.0, state(q=q), started_s=0.0)
    assert m.mode is Mode.POLICY  # within the 0.1 rad margin
    q[3] = 1.11
    m.check_state(0.0, state(q=q), started_s=0.0)
    assert m.mode is Mode.DAMPING and "joint 3" in m.fault



def test_each_mode_commands_what_it_should():
    c, m = controller(np.zeros(N), Mode.PASSIVE)
    q, dq, kp, kd, tau = c.command_for(Mode.PASSIVE, 0.0, state())
    assert not kp.any() and not kd.any() and not tau.any()  # zero torque
    m.mode, m.entered_s, c.move_from_q = Mode.MOVE_TO_DEFAULT, 0.0, np.zeros(N)
    q, _, kp, kd, _ = c.command_for(Mode.MOVE_TO_DEFAULT, 1.0, state())
    np.testing.assert_allclose(q, 0.25)  # halfway from zeros to the default 0.5
    assert (kp == 40).all() and (kd == 2).all()
    q, *_ = c.command_for(Mode.MOVE_TO_DEFAULT, 3.0, state())
    np.testing.assert_allclose(q, 0.5)
    q, *_ = c.command_for(Mode.HOLD, 0.0, state())
    np.testing.assert_allclose(q, 0.5)
    q, _, kp, kd, _ = c.command_for(Mode.DAMPING, 0.0, state())
    assert not kp.any() and (kd == 2).all()


def test_policy_targets_are_clamped_to_the_limits_and_rate_limited():
    output = np.full(N, 0.5)
    output[0], output[1] = 1.6, 0.95  # past the upper limit 1.0 (within the 1 rad margin); a step of 0.45
    c, m = controller(output, Mode.POLICY)
    c.previous_q = np.full(N, 0.5)
    q, *_ = c.command_for(Mode.POLICY, 0.0, state())
    assert m.mode is Mode.POLICY
    assert q[0] == pytest.approx(0.7)  # clamped to 1.0, then 10 rad/s x 20 ms from 0.5
    assert q[1] == pytest.approx(0.7)
    assert q[2] == pytest.approx(0.5)


@pytest.mark.parametrize("bad, cause", [(np.nan, "not finite"), (np.inf, "not finite"), (2.5, "out-of-range")])
def test_a_bad_policy_output_damps_and_writes_no_target(bad, cause):
    output = np.zeros(N)
    output[5] = bad
    c, m = controller(output, Mode.POLICY)
    q, dq, kp, kd, tau = c.command_for(Mode.POLICY, 0.0, state())
    assert m.mode is Mode.DAMPING and cause in m.fault
    assert all(np.isfinite(v).all() for v in (q, dq, kp, kd, tau))
    assert not kp.any()


@pytest.fixture
def g1_bundle(tmp_path) -> Path:
    """A G1 bundle's YAML (docs/results/leapp) with a stand-in graph file: enough for every check before the runtime loads
    the graph."""
    path = tmp_path / G1_BUNDLE_YAML.name
    path.write_text(G1_BUNDLE_YAML.read_text())
    (tmp_path / "Velocity-Height-G1-Student-Recurrent-v0.onnx").write_bytes(b"")
    return path


def test_bundle_checks(tmp_path, g1_bundle):
    g1 = ROBOTS["g1"]
    assert read_deploy_bundle(str(g1_bundle), g1).command_elements == ("lin_vel_x", "lin_vel_y", "ang_vel_z",
                                                                       "base_height")
    with pytest.raises(DeployError, match="Velocity-Height-G1-Student-Recurrent-v0.onnx is not next to it"):
        read_deploy_bundle(str(G1_BUNDLE_YAML), g1)
    with pytest.raises(DeployError, match="no file"):
        read_deploy_bundle(str(tmp_path / "missing.yaml"), g1)
    with pytest.raises(DeployError, match="t1.xml"):
        read_deploy_bundle(str(T1_BUNDLE), g1)
    (tmp_path / "other.yaml").write_text("a: 1\n")
    with pytest.raises(DeployError, match="not a LEAPP bundle"):
        read_deploy_bundle(str(tmp_path / "other.yaml"), g1)
    bundle = yaml.safe_load(g1_bundle.read_text())
    task = bundle["pipeline"]["configs"]["task"]
    bundle["pipeline"]["inputs"][task].append("root_lin_vel_b")
    g1_bundle.write_text(yaml.safe_dump(bundle))
    with pytest.raises(DeployError, match="root_lin_vel_b"):
        read_deploy_bundle(str(g1_bundle), g1)


def deploy(*args):
    return subprocess.run([sys.executable, "-m", "agile", "deploy", *args], capture_output=True, text=True,
                          timeout=120, cwd=REPO)


@pytest.mark.parametrize("args, message", [
    (["--bundle", str(T1_BUNDLE), "--interface", "lo"], "not the g1's"),
    (["--bundle", "no/such/bundle.yaml", "--interface", "lo"], "--bundle: no file no/such/bundle.yaml"),
    (["--bundle", "G1", "--interface", "no_such_if0"], "--interface: no network interface 'no_such_if0'"),
    (["--bundle", "G1", "--interface", "lo", "--command", "0.5", "0", "0"], "takes 4 values"),
    (["--bundle", "G1", "--interface", "lo", "--robot", "h1"], "--robot: 'h1'"),
    (["--bundle", "G1", "--interface", "lo", "--duration_s", "0"], "--duration_s must be positive"),
])
def test_bad_input_is_one_line_and_exit_2(args, message, g1_bundle):
    result = deploy(*[str(g1_bundle) if a == "G1" else a for a in args])
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr
    assert "[deploy]" not in result.stdout  # refused before DDS started: nothing was written


def test_t1_state_conversion_and_command_up_to_the_sdk():
    booster = pytest.importorskip("booster_robotics_sdk_python")
    from agile.deploy import booster_t1

    # the binding's LowState cannot be filled from Python (read-only fields): the same attribute names, checked
    assert {"motor_state_serial", "imu_state"} <= set(dir(booster.LowState()))
    assert {"q", "dq", "tau_est"} <= set(dir(booster.MotorState()))
    assert {"rpy", "gyro"} <= set(dir(booster.ImuState()))
    msg = SimpleNamespace(motor_state_serial=[SimpleNamespace(q=0.01 * i, dq=0.1, tau_est=1.0) for i in range(23)],
                          imu_state=SimpleNamespace(rpy=[0.1, -0.2, 0.3], gyro=[1.0, 2.0, 3.0]))
    s = booster_t1.robot_state(msg, 1.0, 5)
    np.testing.assert_allclose(s.q[:3], [0.0, 0.01, 0.02])
    # gravity seen by an IMU rolled 0.1 and pitched -0.2 rad: (sin p, -sin r cos p, -cos r cos p)
    np.testing.assert_allclose(s.projected_gravity(), [math.sin(-0.2), -math.sin(0.1) * math.cos(0.2),
                                                       -math.cos(0.1) * math.cos(0.2)], atol=1e-9)
    z = np.zeros(23)
    cmd = booster_t1.low_cmd(np.arange(23) * 0.1, z, z + 5, z + 1, z)
    assert cmd.cmd_type == booster.LowCmdType.SERIAL and len(cmd.motor_cmd) == 23
    assert cmd.motor_cmd[3].q == pytest.approx(0.3) and cmd.motor_cmd[3].kp == 5.0


def test_the_simulated_motor_drivers_apply_pd_within_the_limits():
    pytest.importorskip("unitree_sdk2py")
    from agile.deploy.simulator import G1Simulation, g1_robot_config
    from agile.deploy.unitree_g1 import MotorCommand

    cfg = g1_robot_config()
    sim = G1Simulation(cfg, gantry_release_s=10.0)
    z = np.zeros(N)
    sim.apply(MotorCommand(q=z + 0.1, dq=z, kp=z + 10.0, kd=z, tau=z + 0.5, enabled=np.ones(N, bool),
                           received_s=0.0))
    q0 = sim.data.qpos[sim.robot.qpos_adr].copy()
    sim.step()
    np.testing.assert_allclose(sim.tau, np.minimum(10.0 * (0.1 - q0) + 0.5, cfg["effort_limit"]), atol=1e-9)
    assert sim.on_gantry and sim.data.qpos[2] == pytest.approx(cfg["default_root_height_m"])
    big = MotorCommand(q=z + 3.0, dq=z, kp=z + 1000.0, kd=z, tau=z, enabled=np.ones(N, bool), received_s=0.0)
    sim.apply(big)
    sim.step()
    assert np.all(np.abs(sim.tau) <= np.array(cfg["effort_limit"]) + 1e-9)
    sim.apply(MotorCommand(q=z + 3.0, dq=z, kp=z + 1000.0, kd=z, tau=z, enabled=np.zeros(N, bool), received_s=0.0))
    sim.step()
    assert not sim.tau.any()  # motors not enabled give no torque


def test_t1_link_writes_a_command_through_the_sdk_on_loopback():
    pytest.importorskip("booster_robotics_sdk_python")
    import random

    from agile.deploy import booster_t1

    booster_t1.start_dds("lo", random.randint(100, 230))
    link = booster_t1.T1Link()
    z = np.zeros(23)
    link.write(z, z, z, z + 1.0, z)
    assert link.written == 1 and link.latest() is None  # no robot on loopback: no state
    link.close()


def test_a_start_from_the_keyboard_moves_from_where_the_joints_are():
    from agile.deploy.controller import LoopResult

    c, m = controller(np.zeros(N), Mode.PASSIVE)
    c.link = FakeLink(state(0.0, q=np.full(N, -0.3)))
    result = LoopResult(m.transitions)
    c.step(0.0, 0.0, result, None)
    assert m.mode is Mode.PASSIVE and not c.link.written[-1][1].any()  # passive: zero torque
    c.signals.start = True
    c.step(0.02, 0.0, result, None)
    assert m.mode is Mode.MOVE_TO_DEFAULT and m.transitions[-1].cause == "the keyboard"
    np.testing.assert_allclose(c.link.written[-1][0], -0.3)  # the move starts at the joints, not at the default
    m.advance(2.02, c.link.state)
    c.signals.start = True
    c.link.state = state(2.03, tick=1)
    c.step(2.03, 0.0, result, policy_duration_s=5.0)
    assert m.mode is Mode.POLICY and result.policy_started_s == 2.03
    c.link.state = state(7.04, tick=2)
    c.step(7.04, 0.0, result, policy_duration_s=5.0)
    assert m.mode is Mode.DAMPING and result.policy_ended_s == 7.04


def test_the_default_command_of_a_height_policy_stands_at_its_default_height(g1_bundle):
    from agile.run.deploy import default_command

    np.testing.assert_allclose(default_command(read_deploy_bundle(str(g1_bundle), ROBOTS["g1"])), [0, 0, 0, 0.72])


TEACHER_IO = REPO / "agile/data/frozen_policies/Velocity-Height-G1-Teacher-v0/io_descriptor.yaml"
TEACHER_POLICY = TEACHER_IO.parent / "policy.pt"


def test_descriptor_checks(tmp_path):
    from agile.deploy.robots import read_deploy_descriptor

    g1 = ROBOTS["g1"]
    with pytest.raises(DeployError, match=r"reads \['root_lin_vel_b'\]"):  # the teacher reads the base velocity
        read_deploy_descriptor(str(TEACHER_IO), str(TEACHER_POLICY), g1)
    descriptor = yaml.safe_load(TEACHER_IO.read_text())
    descriptor["observations"]["policy"] = [t for t in descriptor["observations"]["policy"]
                                            if t["func"] != "base_lin_vel"]
    sensed = tmp_path / "io_descriptor.yaml"
    sensed.write_text(yaml.safe_dump(descriptor))
    exported = read_deploy_descriptor(str(sensed), str(TEACHER_POLICY), g1)
    assert exported.command_elements == ("lin_vel_x", "lin_vel_y", "ang_vel_z", "base_height")
    assert set(exported.inputs) == {"command", "root_ang_vel_b", "root_quat_w", "joint_pos", "joint_vel"}
    assert exported.policy_file == str(TEACHER_POLICY) and exported.control_dt_s == descriptor["control_dt_s"]
    with pytest.raises(DeployError, match="--policy: .* is not a policy.pt or policy.onnx"):
        read_deploy_descriptor(str(sensed), str(sensed), g1)
    with pytest.raises(DeployError, match="--io: no file"):
        read_deploy_descriptor(str(tmp_path / "missing.yaml"), str(TEACHER_POLICY), g1)
    with pytest.raises(DeployError, match="t1.xml"):
        read_deploy_descriptor(str(sensed), str(TEACHER_POLICY), ROBOTS["t1"])
    for change, match in (({"version": 1}, "version 1"), ({"observations": {"policy": [
            {"name": "heights", "func": "height_scan"}]}}, r"heights \(height_scan\)"),
            ({"actions": [{"name": "a", "type": "JointEffortAction"}]}, r"a \(JointEffortAction\)")):
        sensed.write_text(yaml.safe_dump({**descriptor, **change}))
        with pytest.raises(DeployError, match=match):
            read_deploy_descriptor(str(sensed), str(TEACHER_POLICY), g1)
    sensed.write_text("a: 1\n")
    with pytest.raises(DeployError, match="not an IO descriptor"):
        read_deploy_descriptor(str(sensed), str(TEACHER_POLICY), g1)


@pytest.mark.parametrize("args, message", [
    (["--interface", "lo"], "give either --bundle, or --io and --policy"),
    (["--io", str(TEACHER_IO), "--interface", "lo"], "give either --bundle, or --io and --policy"),
    (["--bundle", "G1", "--io", str(TEACHER_IO), "--policy", str(TEACHER_POLICY), "--interface", "lo"],
     "give either --bundle, or --io and --policy"),
    (["--io", str(TEACHER_IO), "--policy", str(TEACHER_POLICY), "--interface", "lo"], "root_lin_vel_b"),
    (["--bundle", str(T1_BUNDLE), "--robot", "t1", "--interface", "lo", "--command_topic", "rt/cmd_vel"],
     "--command_topic is read over Unitree's DDS participant"),
    (["--bundle", "G1", "--interface", "lo", "--command_topic", "rt/cmd_vel", "--remote"],
     "--command_topic and --remote"),
    (["--bundle", "G1", "--interface", "lo", "--command_timeout_s", "0"], "--command_timeout_s must be positive"),
])
def test_bad_policy_and_command_input_is_one_line_and_exit_2(args, message, g1_bundle):
    result = deploy(*[str(g1_bundle) if a == "G1" else a for a in args])
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.stderr


