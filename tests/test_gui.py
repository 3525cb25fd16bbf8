"""The GUI's parts without a browser: sliders drive the env as a policy would, the mirrored twin receives the
symmetry map's targets, the object follows its sliders, the panels read env 0, and bad debug configs fail
at build naming the term."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest
from browser import free_port

import agile.tasks  # noqa: F401
from agile.gui import ActionSliders, BrowserViewer, limb_of
from agile.gui.panels import VALUES_EVERY_STEPS
from agile.gui.viewer import camera_pose
from agile.rl_env import ManagerBasedRLEnv
from agile.rl_env.managers import ActionTerm
from agile.tasks.debug.debug_env_cfg import ObjectActionsCfg, g1_object_debug_env_cfg
from agile.utils.config import ConfigError, configclass


@pytest.fixture(scope="module")
def gui():
    """The object debug task (one env, CPU) with its viewer and sliders on a free local port."""
    env = gym.make("Debug-G1-Object-v0", device="cpu").unwrapped
    viewer = BrowserViewer(env, free_port())
    sliders = ActionSliders(viewer.server, env)
    yield env, viewer, sliders
    viewer.close()


def step(env, viewer, sliders, count: int = 5) -> None:
    for _ in range(count):
        env.step(sliders.actions())
        viewer.render(env, 0.0)
        sliders.update()


def joint_sliders(sliders):
    (joints,) = sliders.joints
    return joints, {name: k for k, name in enumerate(joints.term.joint_names)}


def test_joints_are_grouped_by_limb():
    assert limb_of("left_hip_pitch_joint") == "left leg"
    assert limb_of("Right_Ankle_Roll") == "right leg"
    assert limb_of("left_wrist_yaw_joint") == "left arm"
    assert limb_of("waist_roll_joint") == "waist"
    assert limb_of("Waist") == "waist"
    assert limb_of("AAHead_yaw") == "head"
    assert limb_of("left_hand_thumb_0_joint") == "left hand"
    assert limb_of("tail_joint") == "other"


def test_sliders_set_the_robot_targets_and_the_twin_receives_their_mirror(gui):
    env, viewer, sliders = gui
    joints, index = joint_sliders(sliders)
    assert len(joints.sliders) == 29 and joints.low[index["left_knee_joint"]] < joints.high[index["left_knee_joint"]]
    values = joints.targets()
    values[index["left_shoulder_roll_joint"]] = 0.7  # roll: the mirror turns the other way
    values[index["left_shoulder_pitch_joint"]] = -0.4  # pitch: the mirror turns the same way
    values[index["waist_yaw_joint"]] = 0.3  # on the centre line: mirrored onto itself, sign flipped
    joints.set_targets(values)
    step(env, viewer, sliders)
    robot, twin = env.scene["robot"], env.scene["mirrored_robot"]
    name = robot.joint_names.index
    assert robot.joint_pos_target[0, name("left_shoulder_roll_joint")].item() == pytest.approx(0.7)
    assert twin.joint_pos_target[0, name("right_shoulder_roll_joint")].item() == pytest.approx(-0.7)
    assert twin.joint_pos_target[0, name("right_shoulder_pitch_joint")].item() == pytest.approx(-0.4)
    assert twin.joint_pos_target[0, name("waist_yaw_joint")].item() == pytest.approx(-0.3)
    # the twin actually moves there
    assert twin.joint_pos[0, name("right_shoulder_roll_joint")].item() < -0.3
    joints.last_moved = index["left_shoulder_roll_joint"]
    joints.update()
    assert "left_shoulder_roll_joint`: +0.700 rad" in joints.readout.content
    assert "right_shoulder_roll_joint`: -0.700 rad" in joints.readout.content


def test_mirror_left_to_right_and_zero(gui):
    env, viewer, sliders = gui
    joints, index = joint_sliders(sliders)
    values = joints.targets()
    values[index["left_hip_roll_joint"]] = 0.3
    values[index["right_hip_roll_joint"]] = 0.1
    values[index["left_elbow_joint"]] = 0.9
    values[index["waist_roll_joint"]] = 0.2
    joints.set_targets(values)
    joints.mirror_left_to_right()
    after = joints.targets()
    assert after[index["right_hip_roll_joint"]] == pytest.approx(-0.3, abs=1e-6)
    assert after[index["right_elbow_joint"]] == pytest.approx(0.9, abs=1e-6)
    assert after[index["left_hip_roll_joint"]] == pytest.approx(0.3, abs=1e-6)  # the left side is kept
    assert after[index["waist_roll_joint"]] == pytest.approx(0.0, abs=1e-6)  # a symmetric pose has no waist roll
    joints.set_targets([0.0] * len(joints.sliders))
    knee = index["left_knee_joint"]  # its range starts above 0: zero is clamped into it
    assert joints.targets()[knee] == pytest.approx(max(0.0, joints.low[knee]))
    assert all(v == pytest.approx(min(max(0.0, lo), hi)) for v, lo, hi in zip(joints.targets(), joints.low, joints.high))


def test_object_sliders_pose_the_object_and_the_rewards_follow(gui):
    env, viewer, sliders = gui
    (objects,) = [p for p in sliders.parts if p not in sliders.joints]
    cube = env.scene["object"]
    start = objects.default_pos.tolist()
    objects.sliders[2].value = float(start[2]) + 0.2  # z up 20 cm: lifted
    objects.sliders[5].value = math.pi / 2  # yaw a quarter turn
    step(env, viewer, sliders)
    assert cube.root_pos_env[0].tolist() == pytest.approx([start[0], start[1], start[2] + 0.2], abs=1e-4)
    assert abs(cube.root_quat_w[0, 2].item()) == pytest.approx(math.sqrt(0.5), abs=1e-4)  # about z
    lifted = viewer.rewards.latest()
    assert lifted["lifting_object"] == pytest.approx(0.5) and lifted["is_alive"] == pytest.approx(1.0)
    objects.reset()
    step(env, viewer, sliders)
    assert cube.root_pos_env[0].tolist() == pytest.approx(start, abs=1e-4)
    assert viewer.rewards.latest()["lifting_object"] == 0.0
    # the plot holds the last steps of every term, newest last
    assert viewer.rewards.history.shape == (len(env.reward_manager.step_reward), 200)
    assert viewer.rewards.history[viewer.rewards.names.index("lifting_object"), -6] == pytest.approx(0.5)
    history = viewer.rewards.history.copy()
    viewer.render(env, 0.0)  # paused: drawn again without a step, nothing added
    assert np.array_equal(history, viewer.rewards.history, equal_nan=True)
    for _ in range(VALUES_EVERY_STEPS):  # the latest values as text (uPlot's legend shows them only under the mouse)
        step(env, viewer, sliders)
    assert "**is_alive** +1.000" in viewer.rewards.values_text.content


def test_reset_button_resets_the_env_and_the_sliders(gui):
    env, viewer, sliders = gui
    joints, index = joint_sliders(sliders)
    joints.set_targets([0.5 * (lo + hi) for lo, hi in zip(joints.low, joints.high)])
    joints._reset()  # what the Reset button calls
    assert sliders.reset_requested
    assert joints.targets() == pytest.approx(joints.default_targets.tolist(), abs=1e-6)
    env.reset()
    sliders.after_reset()
    assert not sliders.reset_requested


def test_the_camera_looks_at_the_target_from_its_pitch_and_yaw():
    target = np.array([1.0, 2.0, 0.8])
    position, distance = camera_pose(target, spread_m=0.0, pitch_deg=-30.0, yaw_deg=180.0)
    assert np.linalg.norm(target - position) == pytest.approx(distance)
    direction = (target - position) / distance
    assert direction == pytest.approx([-math.cos(math.radians(30)), 0.0, -0.5], abs=1e-9)
    assert camera_pose(target, spread_m=2.0)[1] > distance  # two robots apart: further back


def test_a_mirror_of_an_unknown_term_lists_the_terms():
    cfg = g1_object_debug_env_cfg()
    cfg.actions.mirrored_joint_pos.source_action_name = "joints"
    with pytest.raises(ConfigError, match=r"action term 'mirrored_joint_pos': source_action_name 'joints'.*"
                                          r"\['joint_pos', 'mirrored_joint_pos', 'object_pose'\]"):
        ManagerBasedRLEnv(cfg, device="cpu")


def test_posing_a_dynamic_object_is_refused():
    cfg = g1_object_debug_env_cfg()
    cfg.scene.entities["object"] = dataclasses.replace(cfg.scene.entities["object"], body_type="dynamic", mass_kg=0.1)
    with pytest.raises(ConfigError, match=r"action term 'object_pose'.*kinematic.*it is dynamic"):
        ManagerBasedRLEnv(cfg, device="cpu")


def test_object_pose_ranges_are_checked():
    cfg = g1_object_debug_env_cfg()
    cfg.actions.object_pose.ranges = {"x": (0.2, -0.2), "height": (0.0, 1.0)}
    with pytest.raises(ConfigError, match=r"object_pose.*unknown axes \['height'\]"):
        ManagerBasedRLEnv(cfg, device="cpu")


class ForceAction(ActionTerm):
    """A policy output the sliders know nothing about."""

    @property
    def action_dim(self) -> int:
        return 2

    def process_actions(self, actions):
        pass

    def apply_actions(self):
        pass


@configclass
class ForceActionCfg:
    class_type: type = ForceAction
    asset_name: str = "robot"


@configclass
class ActionsWithPushCfg(ObjectActionsCfg):
    push = ForceActionCfg()


def test_sliders_refuse_a_term_they_cannot_drive():
    cfg = g1_object_debug_env_cfg()
    cfg.actions = ActionsWithPushCfg()
    env = ManagerBasedRLEnv(cfg, device="cpu")
    viewer = BrowserViewer(env, free_port())
    try:
        with pytest.raises(ValueError, match=r"action term 'push' \(ForceAction\) has no GUI controls"):
            ActionSliders(viewer.server, env)
    finally:
        viewer.close()


def test_object_sliders_start_at_the_objects_place_in_its_env():
    from agile.tasks.debug.debug_env_cfg import CUBE_POSITION_M

    env = gym.make("Debug-G1-Object-v0", device="cpu", num_envs=2).unwrapped
    assert env.env_origins.abs().sum() > 0  # envs away from the world origin: env and world frames differ
    viewer = BrowserViewer(env, free_port())
    try:
        sliders = ActionSliders(viewer.server, env)
        (objects,) = [p for p in sliders.parts if p not in sliders.joints]
        assert [s.value for s in objects.sliders[:3]] == pytest.approx(CUBE_POSITION_M)
        step(env, viewer, sliders, count=2)
        for env_pos in env.scene["object"].root_pos_env.tolist():
            assert env_pos == pytest.approx(CUBE_POSITION_M, abs=1e-4)
    finally:
        viewer.close()


def test_ctrl_c_ends_the_play_loop_between_steps_and_a_second_one_interrupts():
    """The first SIGINT only asks the loop to stop (no KeyboardInterrupt inside a viser or Warp call, which could
    leave a lock held and hang the shutdown); a second one interrupts at once; the handler is put back after."""
    import os
    import signal

    from agile.run.play import CtrlC

    original = signal.getsignal(signal.SIGINT)
    # a test worker may run with SIGINT ignored, where CtrlC rightly installs nothing: test it in a normal process
    signal.signal(signal.SIGINT, signal.default_int_handler)
    before = signal.getsignal(signal.SIGINT)
    ctrl_c = CtrlC()
    try:
        assert not ctrl_c.requested
        os.kill(os.getpid(), signal.SIGINT)
        assert ctrl_c.requested
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
    finally:
        ctrl_c.restore()
        restored = signal.getsignal(signal.SIGINT)
        signal.signal(signal.SIGINT, original)
    assert restored is before
