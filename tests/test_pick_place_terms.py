"""Pick-and-place terms on scripted poses, against hand-computed values: the palm frame, the object observations,
rewards and terminations, and the delta joint-position action."""

import math
from types import SimpleNamespace

import torch
from fakes import FakeEnv

from agile.tasks.pick_place import mdp
from agile.rl_env.managers import SceneEntityCfg

PALM = SceneEntityCfg("robot", body_names="wrist")
OFFSET_M = (0.11, 0.03, 0.0)
YAW_90 = [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]


class FakeCommand:
    """What the terms read from a TrackingCommand, set by hand."""

    def __init__(self, **values):
        self.__dict__.update(values)


def scripted_env(reference: FakeCommand) -> FakeEnv:
    """Env 0: the wrist at (1, 2, 3) turned 90° about z, the object 10 cm to the wrist's +y of the palm.
    Env 1: the wrist at the origin, unturned, the object 1 m up."""
    env = FakeEnv(2, joint_names=("a", "b", "c"), body_names=("base", "wrist"))
    PALM.resolve(env)
    env.robot.body_pose_w[0, 1] = torch.tensor([1.0, 2.0, 3.0, *YAW_90])
    env.robot.root_quat_w = torch.tensor([YAW_90, [0.0, 0.0, 0.0, 1.0]])
    env.robot.root_lin_vel_w, env.robot.root_ang_vel_w = torch.zeros(2, 3), torch.zeros(2, 3)
    palm_0 = [1.0 - 0.03, 2.0 + 0.11, 3.0]  # the offset turned by 90°: x -> y, y -> -x
    object_pos = torch.tensor([[palm_0[0], palm_0[1] + 0.1, palm_0[2]], [0.0, 0.0, 1.0]])
    env.scene["object"] = SimpleNamespace(root_pos_w=object_pos, root_pos_env=object_pos.clone())
    env.command_manager = SimpleNamespace(get_term=lambda name: reference)
    return env


def test_palm_frame_and_object_observations():
    reference = FakeCommand(object_pos_w=torch.tensor([[0.97, 2.11, 3.3], [0.0, 0.0, 1.0]]))
    env = scripted_env(reference)
    palm_pos, _ = mdp.palm_pose_w(env, PALM, OFFSET_M)
    torch.testing.assert_close(palm_pos, torch.tensor([[0.97, 2.11, 3.0], [0.11, 0.03, 0.0]]))
    # 10 cm along world +y is the palm's +x once it is turned 90° about z
    torch.testing.assert_close(mdp.object_to_hand_pos_b(env, PALM, OFFSET_M),
                               torch.tensor([[0.1, 0.0, 0.0], [-0.11, -0.03, 1.0]]))
    # reference 0.3 m above and 0.1 m along world -y of the object: in the turned root frame (x = world y)
    torch.testing.assert_close(mdp.object_pos_error(env, "reference"),
                               torch.tensor([[-0.1, 0.0, 0.3], [0.0, 0.0, 0.0]]))
    rewards = mdp.motion_object_position_error_exp(env, "reference", std=0.3)
    torch.testing.assert_close(rewards, torch.tensor([math.exp(-(0.1**2 + 0.3**2) / 0.09), 1.0]))


def test_hand_object_distance_is_tracked_while_held_and_fades_after_the_release():
    reference = FakeCommand(in_hand=torch.tensor([True, False]), released=torch.tensor([False, True]),
                            steps_since_release=torch.tensor([0, 25]))
    env = scripted_env(reference)
    env.scene["object"].root_pos_w[1] = torch.tensor([0.11, 0.13, 0.0])  # 10 cm from env 1's palm
    reward = mdp.hand_object_distance_tracking_exp(env, "reference", std=0.1, release_decay_steps=50,
                                                   palm_cfg=PALM, offset_m=OFFSET_M)
    torch.testing.assert_close(reward, torch.tensor([math.exp(-1.0), 0.5 * math.exp(-1.0)]))
    reference.in_hand, reference.released = torch.tensor([False, False]), torch.tensor([False, False])
    reward = mdp.hand_object_distance_tracking_exp(env, "reference", std=0.1, release_decay_steps=50,
                                                   palm_cfg=PALM, offset_m=OFFSET_M)
    torch.testing.assert_close(reward, torch.zeros(2))  # before the grasp


def test_object_lift_and_bounds():
    env = scripted_env(FakeCommand())
    torch.testing.assert_close(mdp.object_is_lifted(env, minimal_height_m=2.0), torch.tensor([1.0, 0.0]))
    bounds = mdp.out_of_bound(env, z_range_m=(0.6, 1.5), asset_cfg=SceneEntityCfg("object"))
    assert bounds.tolist() == [True, False]


def test_goal_and_posture_terms_ramp_in_with_progress():
    joint_ids = torch.tensor([0, 2])
    reference = FakeCommand(progress=torch.tensor([0.9, 0.5]), joint_ids=joint_ids,
                            final_joint_pos=torch.tensor([[0.5, 0.5], [0.0, 0.0]]),
                            robot_joint_pos=torch.zeros(2, 2))
    env = scripted_env(reference)
    env.robot.joint_vel[:] = torch.tensor([0.3, 9.0, 0.0])  # joint b is not tracked
    static = mdp.static_at_goal_exp(env, "reference", progress_threshold=0.8, joint_vel_std=0.3, root_vel_std=0.3)
    torch.testing.assert_close(static, torch.tensor([0.5 * math.exp(-1.0), 0.0]))
    posture = mdp.nominal_posture_at_end_exp(env, "reference", progress_threshold=0.85, std=0.5)
    torch.testing.assert_close(posture, torch.tensor([math.exp(-2.0), 0.0]))


def test_delta_joint_action_accumulates_clips_and_restarts_from_the_joints():
    env = FakeEnv(2, joint_names=("waist_yaw_joint", "arm_joint", "left_arm_joint"))
    env.robot.default_joint_pos[:] = torch.tensor([0.0, 0.0, 0.7])
    env.robot.joint_pos[:] = torch.tensor([[0.1, 0.2, 0.0], [0.0, -0.5, 0.0]])
    cfg = mdp.DeltaJointPositionActionCfg(joint_names=["arm_joint", "waist_yaw_joint"], scale=0.05,
                                          joint_limits={"waist_yaw_joint": (-0.2, 0.2)},
                                          steady_joint_names=["left_arm_joint"])
    action = cfg.class_type(cfg, env)
    assert action.joint_names == ["arm_joint", "waist_yaw_joint"]
    for _ in range(3):  # from the joints' positions, three steps of 0.05 · (1, 1) (waist clipped at 0.2)
        action.process_actions(torch.ones(2, 2))
    action.apply_actions()
    torch.testing.assert_close(env.robot.joint_pos_target, torch.tensor([[0.2, 0.35, 0.7], [0.15, -0.35, 0.7]]))
    action.process_actions(-40.0 * torch.ones(2, 2))  # down to the soft limits (the fake robot's: ±1 rad)
    torch.testing.assert_close(action.processed_actions, torch.tensor([[-1.0, -0.2]] * 2))
    action.reset(torch.tensor([False, True]))  # env 1 starts again from where its joints are
    action.process_actions(torch.zeros(2, 2))
    torch.testing.assert_close(action.processed_actions, torch.tensor([[-1.0, -0.2], [-0.5, 0.0]]))
    # the action that puts the targets somewhere in one step (a replayed reference): from the targets, and from the
    # joints in an env that starts an episode
    action.reset(torch.tensor([False, True]))
    targets = torch.tensor([[0.3, -0.1], [0.4, 0.15]])
    action.process_actions(action.actions_for_targets(targets))
    torch.testing.assert_close(action.processed_actions, targets)
