"""PickPlace-G1-Debug-v0 in the GUI (without a browser): the task's MDP, one env; its sliders drive the upper body
through the task's delta action and the frozen lower body through its command; a PickPlace-G1-v0 policy plays
in it unchanged, from `agile play`."""

from __future__ import annotations

import gymnasium as gym
import pytest
from browser import free_port

import agile.tasks
from agile.gui import ActionSliders, BrowserViewer

DEBUG = "PickPlace-G1-Debug-v0"


@pytest.fixture(scope="module")
def gui():
    env = gym.make(DEBUG, device="cpu").unwrapped
    env.reset()
    viewer = BrowserViewer(env, free_port())
    sliders = ActionSliders(viewer.server, env)
    yield env, viewer, sliders
    viewer.close()
    env.close()


def step(env, viewer, sliders, count: int = 10) -> None:
    for _ in range(count):
        env.step(sliders.actions())
        viewer.render(env, 0.0)
        sliders.update()


def test_the_debug_variant_is_the_task_with_one_env_from_the_first_frame():
    task, _ = agile.tasks.load_cfgs("PickPlace-G1-v0")
    debug, _ = agile.tasks.load_cfgs(DEBUG)
    assert debug.num_envs == 1 and debug.commands.reference.start_step_range == (0, 0)
    for section in ("actions", "observations", "rewards", "terminations", "events"):
        assert getattr(debug, section) == getattr(task, section), section
    assert debug.scene == task.scene


def test_arm_sliders_set_the_upper_body_targets_through_the_delta_action(gui):
    env, viewer, sliders = gui
    (joints,) = sliders.joints
    term = env.action_manager.get_term("upper_body_joint_pos")
    assert joints.term is term and len(joints.sliders) == 17
    # the sliders span the targets the delta action can reach: AGILE's waist limits, the arm's soft limits
    assert [s.min for s in joints.sliders] == pytest.approx(term.low[0].tolist())
    assert [s.max for s in joints.sliders] == pytest.approx(term.high[0].tolist())
    waist_yaw = term.joint_names.index("waist_yaw_joint")
    assert joints.sliders[waist_yaw].max == pytest.approx(0.2, abs=1e-6)
    values = joints.targets()
    elbow = term.joint_names.index("right_elbow_joint")
    start = float(term.robot.joint_pos[0, term.joint_ids[elbow]])
    values[elbow] = 1.2
    joints.set_targets(values)
    step(env, viewer, sliders, count=25)
    robot = env.scene["robot"]
    robot_elbow = robot.joint_names.index("right_elbow_joint")
    assert robot.joint_pos_target[0, robot_elbow].item() == pytest.approx(1.2)
    assert robot.joint_pos[0, robot_elbow].item() - start > 0.5  # it moves there (the arm sags a little under gravity)


def test_command_sliders_start_standing_and_walk_the_frozen_lower_body(gui):
    env, viewer, sliders = gui
    (command,) = [p for p in sliders.parts if p not in sliders.joints]
    term = env.action_manager.get_term("lower_body_joint_pos")
    assert [s.value for s in command.sliders] == pytest.approx([0.0, 0.0, 0.0, 0.72])
    assert [s.min for s in command.sliders] == pytest.approx(term.command_low.tolist())
    assert [s.max for s in command.sliders] == pytest.approx(term.command_high.tolist())
    (joints,) = sliders.joints
    joints.set_targets(joints.default_targets.tolist())
    env.reset()
    robot = env.scene["robot"]
    start_y = float(robot.root_pos_w[0, 1])
    command.sliders[1].value = -0.4  # sideways, to its right along the table (which stands 0.28 m ahead)
    step(env, viewer, sliders, count=40)
    assert term.command[0].tolist() == pytest.approx([0.0, -0.4, 0.0, 0.72])
    # 0.8 s at 0.4 m/s asked, from standing: 0.25 m measured (CPU); walking on, within a second more, it leaves the
    # task's bounds around the reference and the episode ends
    assert float(robot.root_pos_w[0, 1]) - start_y < -0.1
    sliders.after_reset()
    assert [s.value for s in command.sliders] == pytest.approx([0.0, 0.0, 0.0, 0.72])


def test_play_runs_a_pick_place_policy_in_the_debug_variant(gui, tmp_path, capsys):
    from rsl_rl.runners import OnPolicyRunner

    from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict
    from agile.run import play

    env, _, _ = gui  # the task's observations and actions: a PickPlace-G1-v0 runner is built on it as on the task
    _, agent_cfg = agile.tasks.load_cfgs("PickPlace-G1-v0")
    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=None, device="cpu")
    checkpoint = tmp_path / "model_0.pt"
    runner.save(str(checkpoint))
    play.main(["--task", DEBUG, "--checkpoint", str(checkpoint), "--device", "cpu", "--viewer", "none",
               "--num_steps", "3", "--trust_checkpoint"])
    out = capsys.readouterr().out
    assert f"{DEBUG}: 1 envs on cpu, policy {checkpoint}" in out and "3 steps" in out


def test_play_opens_the_debug_variant_with_the_shipped_policy_or_else_its_sliders(capsys):
    from agile.run import play

    play.main(["--task", DEBUG, "--device", "cpu", "--num_steps", "2", "--port", str(free_port())])
    shipped = agile.tasks.pretrained_policy(DEBUG)
    source = f"policy {shipped}" if shipped is not None else "the GUI's sliders"
    assert f"{DEBUG}: 1 envs on cpu, {source}" in capsys.readouterr().out


def test_videos_of_pick_and_place_look_over_the_right_shoulder(gui, tmp_path):
    from agile.run.recorders import DEFAULT_CAMERA_OFFSET_M, VideoRecorder

    env, _, _ = gui
    video = VideoRecorder(str(tmp_path / "pick_place.mp4"), env, width=64, height=48)
    video.record(env)
    video.close()
    assert video.camera_offset_m == (-0.8, -1.2, 1.3) != DEFAULT_CAMERA_OFFSET_M and video.frames == 1

