"""PickPlace-G1-Debug-v0 in the GUI (without a browser): the right arm's sliders move the arm, the object's sliders
pose the cube, and the reward plot follows the palm-to-cube distance."""

from __future__ import annotations

import gymnasium as gym
import pytest
from browser import free_port

import agile.tasks  # noqa: F401
from agile.gui import ActionSliders, BrowserViewer
from agile.assets.unitree_g1_with_hands import PALM_BODY, GRASP_POINT_M
from agile.tasks.pick_place import mdp
from agile.rl_env.managers import SceneEntityCfg


@pytest.fixture(scope="module")
def gui():
    env = gym.make("PickPlace-G1-Debug-v0", device="cpu").unwrapped
    viewer = BrowserViewer(env, free_port())
    sliders = ActionSliders(viewer.server, env)
    yield env, viewer, sliders
    viewer.close()


def step(env, viewer, sliders, count: int = 10) -> None:
    for _ in range(count):
        env.step(sliders.actions())
        viewer.render(env, 0.0)
        sliders.update()


def test_arm_sliders_move_the_right_arm_only(gui):
    env, viewer, sliders = gui
    (joints,) = sliders.joints
    assert all(name.startswith("right_") for name in joints.term.joint_names) and len(joints.sliders) == 14
    values = joints.targets()
    values[joints.term.joint_names.index("right_elbow_joint")] = 1.2
    joints.set_targets(values)
    step(env, viewer, sliders, count=25)
    robot = env.scene["robot"]
    elbow = robot.joint_names.index("right_elbow_joint")
    assert robot.joint_pos_target[0, elbow].item() == pytest.approx(1.2)
    assert robot.joint_pos[0, elbow].item() == pytest.approx(1.2, abs=0.1)
    assert robot.root_pos_env[0, 2].item() == pytest.approx(robot.default_root_pose[0, 2].item(), abs=1e-4)  # fixed


def test_object_sliders_pose_the_cube_and_the_palm_reward_follows(gui):
    env, viewer, sliders = gui
    (objects,) = [p for p in sliders.parts if p not in sliders.joints]
    step(env, viewer, sliders, count=2)
    far = viewer.rewards.latest()["palm_to_object"]
    palm = SceneEntityCfg("robot", body_names=PALM_BODY)
    palm.resolve(env)
    palm_pos, _ = mdp.palm_pose_w(env, palm, GRASP_POINT_M)
    offset = (palm_pos[0] - env.env_origins[0]) - objects.default_pos
    for axis in range(3):  # the cube to the palm
        objects.sliders[axis].value = float(objects.default_pos[axis] + offset[axis])
    step(env, viewer, sliders, count=2)
    near = viewer.rewards.latest()["palm_to_object"]
    assert far < 0.5 < near, (far, near)
    cube = env.scene["object"]
    assert cube.root_pos_w[0].tolist() == pytest.approx(palm_pos[0].tolist(), abs=0.02)
