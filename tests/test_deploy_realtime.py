"""`agile deploy` against `agile sim_robot` over loopback DDS, two processes in real time (-m realtime: run apart
from the parallel workers, whose load breaks the timing). Each test has its own random DDS domain, so that two runs
on one machine cannot cross-talk, and every process a timeout, so that a hang fails instead of blocking.

The shipped Velocity-G1-History-v0 policy is exported as a LEAPP bundle once per test run (`agile export`, ~1 min)."""

from __future__ import annotations

import json
import queue
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("unitree_sdk2py")
pytest.importorskip("leapp")

pytestmark = pytest.mark.realtime
REPO = Path(__file__).resolve().parents[1]
TASK = "Velocity-G1-History-v0"
T1_BUNDLE = REPO / "docs/results/leapp/Velocity-T1-v0.yaml"
IN_PROCESS_DOMAIN = random.randint(100, 230)
"""Unitree's channel factory keeps one DDS participant per process: the in-process test's domain."""


@pytest.fixture(scope="session")
def bundle(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("leapp")
    # flat ground: a bundle holds no terrain (byte for byte the bundle of the rough task), and the rough one takes 16 s
    # more to build on a 2-core CPU
    subprocess.run([sys.executable, "-m", "agile", "export", "--task", TASK, "--format", "leapp", "--out", str(out),
                    "env.scene.terrain=null"], check=True, capture_output=True, timeout=600, cwd=REPO)
    return out / TASK / f"{TASK}.yaml"


def domain() -> int:
    return random.choice([d for d in range(100, 231) if d != IN_PROCESS_DOMAIN])


class Process:
    """A command in its own process, its output lines read in a thread (so that waiting for one has a timeout)."""

    def __init__(self, *args):
        self.popen = subprocess.Popen([sys.executable, "-m", "agile", *args], cwd=REPO, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True)
        self.lines: queue.Queue = queue.Queue()
        self.output: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.popen.stdout:
            self.output.append(line)
            self.lines.put(line)

    def wait_for(self, text: str, timeout_s: float) -> str:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.1)
            except queue.Empty:
                if self.popen.poll() is not None and self.lines.empty():
                    break
                continue
            if text in line:
                return line
        raise AssertionError(f"no line with {text!r} within {timeout_s} s; output:\n{''.join(self.output)}")

    def finish(self, timeout_s: float) -> int:
        try:
            return self.popen.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            raise AssertionError(f"still running after {timeout_s} s; output:\n{''.join(self.output)}") from None

    def text(self) -> str:
        time.sleep(0.2)  # the reader thread's last lines
        return "".join(self.output)


class Simulator(Process):
    def __init__(self, tmp_path: Path, domain_id: int, *faults):
        self.out = tmp_path / f"sim_{domain_id}.json"
        super().__init__("sim_robot", "--robot", "g1", "--interface", "lo", "--domain_id", str(domain_id),
                         "--out", str(self.out), *faults)
        self.wait_for("publishing rt/lowstate", 60)

    def stop(self) -> dict:
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGINT)
        assert self.finish(30) == 0, self.text()
        return json.loads(self.out.read_text())


LOADED_MACHINE_STATE_AGE = ("--max_state_age_s", "0.2")
"""For the tests that are not about a stale state: on a 2-core CI machine that runs the simulator and deploy side by
side, a scheduling gap of 67 ms between two states (past the default bound of 3 control periods, 60 ms) was seen and
ended a dry run in damping ("link lost")."""


def deploy_args(bundle: Path, domain_id: int, log: Path, *extra) -> list[str]:
    return ["deploy", "--bundle", str(bundle), "--interface", "lo", "--domain_id", str(domain_id), "--log", str(log),
            *extra]


def test_the_simulators_robot_is_the_bundles(bundle):
    from agile.deploy.simulator import g1_robot_config

    robot = yaml.safe_load(bundle.read_text())["pipeline"]["configs"]["robot"]
    for key, value in g1_robot_config().items():
        if key == "actuators":
            for group, cfg in value.items():
                assert {k: robot[key][group][k] for k in cfg} == cfg, group
        else:
            assert robot[key] == value, key


def test_the_shipped_policy_walks_20_s_at_half_a_metre_per_second(bundle, tmp_path):
    from agile.deploy.simulator import walk_metrics
    from agile.tasks.catalogue import task_entry

    d = domain()
    sim = Simulator(tmp_path, d)
    try:  # refused input against a live robot: exit 2, and the robot got no command
        for bad in (["--bundle", str(T1_BUNDLE)], ["--interface", "no_such_if0"]):
            args = deploy_args(bundle, d, tmp_path / "bad.json", "--autostart")
            args[args.index(bad[0]) + 1] = bad[1]
            refused = subprocess.run([sys.executable, "-m", "agile", *args], capture_output=True, text=True,
                                     timeout=60, cwd=REPO)
            assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
    finally:
        assert sim.stop()["commands_received"] == 0
    sim = Simulator(tmp_path, d)
    log = tmp_path / "walk.json"
    try:
        walk = Process(*deploy_args(bundle, d, log, *LOADED_MACHINE_STATE_AGE, "--autostart", "--duration_s", "20", "--command", "0.5", "0",
                                    "0"))
        assert walk.finish(90) == 0, walk.text()
    finally:
        summary = sim.stop()
    run = json.loads(log.read_text())
    assert [(t["from"], t["to"]) for t in run["transitions"]] == [
        ("passive", "move_to_default"), ("move_to_default", "hold"), ("hold", "policy"), ("policy", "damping")]
    assert "--duration_s 20.0 of policy reached" in run["transitions"][-1]["cause"]
    # the robot's side keeps the newest command: under load a few are overtaken before it reads them
    assert 0.95 * run["commands_written"] <= summary["commands_received"] <= run["commands_written"]
    assert summary["commands_nonfinite"] == 0 and summary["commands_bad_crc"] == 0
    metrics = walk_metrics(summary["samples"], run["policy_started_s"], run["policy_ended_s"], np.array([0.5, 0, 0]))
    assert metrics["window_s"] > 19.5
    assert metrics["max_tilt_rad"] < np.radians(45) and metrics["min_height_m"] > 0.5, metrics
    assert metrics["lin_vel_error_mps"] <= task_entry(TASK).criteria["lin_vel_error_mps"], metrics


def test_the_simulator_killed_damps_within_100_ms_of_the_last_state(bundle, tmp_path):
    d = domain()
    sim = Simulator(tmp_path, d)
    log = tmp_path / "killed.json"
    run = Process(*deploy_args(bundle, d, log, "--autostart", "--damping_s", "0.5"))
    run.wait_for("hold -> policy", 60)
    time.sleep(1.0)
    sim.popen.kill()
    assert run.finish(30) == 1, run.text()
    assert "link lost" in run.text()
    out = json.loads(log.read_text())
    damping = out["transitions"][-1]
    assert damping["from"] == "policy" and damping["to"] == "damping" and "link lost" in damping["cause"]
    assert damping["time_s"] - out["last_state_received_s"] <= 0.1, damping


def test_a_frozen_state_stream_damps(bundle, tmp_path):
    d = domain()
    sim = Simulator(tmp_path, d, "--freeze_after_s", "8")
    log = tmp_path / "frozen.json"
    try:
        run = Process(*deploy_args(bundle, d, log, "--autostart", "--damping_s", "0.5"))
        assert run.finish(60) == 1, run.text()
    finally:
        sim.stop()
    damping = json.loads(log.read_text())["transitions"][-1]
    assert damping["to"] == "damping" and "frozen state stream" in damping["cause"], damping


def test_ctrl_c_damps_then_exits_cleanly(bundle, tmp_path):
    d = domain()
    sim = Simulator(tmp_path, d)
    log = tmp_path / "ctrl_c.json"
    try:
        run = Process(*deploy_args(bundle, d, log, *LOADED_MACHINE_STATE_AGE, "--autostart", "--damping_s", "1.0"))
        run.wait_for("hold -> policy", 60)
        time.sleep(0.5)
        run.popen.send_signal(signal.SIGINT)
        assert run.finish(30) == 0, run.text()
    finally:
        summary = sim.stop()
    out = json.loads(log.read_text())
    assert out["transitions"][-1]["cause"] == "SIGINT (Ctrl-C)" and out["fault"] is None
    assert out["steps_by_mode"]["damping"] >= 45  # damping commands for --damping_s 1.0 at 50 Hz, then the exit
    assert 0.95 * out["commands_written"] <= summary["commands_received"] <= out["commands_written"]


def test_dry_run_writes_nothing(bundle, tmp_path):
    d = domain()
    sim = Simulator(tmp_path, d)
    log = tmp_path / "dry.json"
    try:
        run = Process(*deploy_args(bundle, d, log, *LOADED_MACHINE_STATE_AGE, "--autostart", "--dry_run", "--duration_s", "1",
                                   "--damping_s", "0.2"))
        assert run.finish(60) == 0, run.text()
    finally:
        summary = sim.stop()
    out = json.loads(log.read_text())
    assert out["steps_by_mode"]["policy"] >= 45 and out["commands_written"] == 0
    assert summary["commands_received"] == 0


def test_a_nan_policy_output_damps_and_no_nan_is_ever_written(bundle, tmp_path):
    from agile.deploy.controller import Controller, Signals
    from agile.deploy.policy import DeployPolicy
    from agile.deploy.robots import read_deploy_bundle, robot_spec
    from agile.deploy.safety import Mode, SafetyLimits, SafetyStateMachine
    from agile.deploy.unitree_g1 import G1Link, start_dds

    sim = Simulator(tmp_path, IN_PROCESS_DOMAIN)
    try:
        spec = robot_spec("g1")
        deploy_bundle = read_deploy_bundle(str(bundle), spec)
        policy = DeployPolicy(deploy_bundle, spec)
        calls = {"n": 0}
        real_call = policy.__call__

        class NanAfter25:
            """The bundle's policy with a NaN in its 26th output: the fault the test injects."""

            default_q, kp, kd = policy.default_q, policy.kp, policy.kd

            def reset(self):
                policy.reset()

            def __call__(self, state, command):
                q, kp, kd = real_call(state, command)
                calls["n"] += 1
                if calls["n"] > 25:
                    q[7] = np.nan
                return q, kp, kd

        start_dds("lo", IN_PROCESS_DOMAIN)
        link = G1Link()
        deadline = time.monotonic() + 10
        while link.latest() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        lower, upper = spec.joint_limits()
        machine = SafetyStateMachine(SafetyLimits(move_duration_s=1.0, autostart_hold_s=0.5), lower, upper,
                                     autostart=True)
        controller = Controller(link=link, policy=NanAfter25(), machine=machine, control_dt_s=0.02,
                                velocity_limit=np.full(29, 30.0), command_source=lambda s: np.zeros(3),
                                signals=Signals())
        result = controller.run(policy_duration_s=10.0, damping_s=0.3)
        link.close()
    finally:
        summary = sim.stop()
    assert machine.mode is Mode.DAMPING and "not finite" in machine.fault
    assert machine.transitions[-1].source is Mode.POLICY and calls["n"] == 26
    assert 0.95 * result.commands_written <= summary["commands_received"] <= result.commands_written
    assert summary["commands_nonfinite"] == 0


def test_a_velocity_command_over_a_dds_topic_walks_and_a_silent_topic_stands(bundle, tmp_path):
    """geometry_msgs/Twist on rt/cmd_vel from this process: 0.5 m/s for 7 s of policy, then nothing; the robot walks,
    then stands once the topic has been silent for --command_timeout_s."""
    from agile.deploy.unitree_g1 import VelocityTopic, start_dds

    sim = Simulator(tmp_path, IN_PROCESS_DOMAIN)
    log = tmp_path / "topic.json"
    start_dds("lo", IN_PROCESS_DOMAIN)
    sender = VelocityTopic("rt/cmd_vel")
    try:
        run = Process(*deploy_args(bundle, IN_PROCESS_DOMAIN, log, *LOADED_MACHINE_STATE_AGE, "--autostart",
                                   "--duration_s", "12", "--command_topic", "rt/cmd_vel"))
        run.wait_for("hold -> policy", 60)
        until_s = time.monotonic() + 7.0
        while time.monotonic() < until_s:
            sender.publish(0.5, 0.0, 0.0)
            time.sleep(0.05)
        silent_from_s = time.monotonic()
        assert run.finish(60) == 0, run.text()
    finally:
        summary = sim.stop()
    out = json.loads(log.read_text())
    assert [e["event"] for e in out["command"]["events"]] == ["command topic silent for more than 0.5 s: standing"]
    assert out["command"]["stream_messages"] >= 100 and out["command"]["refused"] == 0
    samples = np.array(summary["samples"])  # wall_monotonic_s, sim_time_s, vx, vy, wz, height, tilt

    def window(start_s, end_s):
        return samples[(samples[:, 0] >= start_s) & (samples[:, 0] <= end_s)]

    walking = window(out["policy_started_s"] + 3.0, silent_from_s)
    standing = window(silent_from_s + 2.0, out["policy_ended_s"])
    assert len(walking) > 100 and len(standing) > 50
    walking_vx_mps, standing_speed_mps = walking[:, 2].mean(), np.linalg.norm(standing[:, 2:4], axis=1).mean()
    # this policy walks a commanded 0.5 m/s slower in MuJoCo (sim2mujoco error 0.235 m/s; 0.26 m/s measured here from
    # 3 s to 7 s of policy, one run, 2026-12-02)
    assert walking_vx_mps > 0.18 and standing_speed_mps < 0.1, (walking_vx_mps, standing_speed_mps)
    assert summary["fell_at_sim_s"] is None or summary["fell_at_sim_s"] > summary["sim_time_s"] - 3.0
