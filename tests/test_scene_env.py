"""A world of two robots, a table and an object, built, stepped and reset through the env (CPU; CUDA too
when there is one): two action terms drive two robots without crosstalk, terms resolve any entity by name."""

import dataclasses

import pytest
import torch
import warp as wp

from agile.assets.booster_t1 import t1_implicit_actuators, t1_robot_cfg
from agile.rl_env import ManagerBasedRLEnv, ManagerBasedRLEnvCfg, mdp
from agile.rl_env.managers import DoneTerm, EventTerm, ObsGroup, ObsTerm, RewTerm, SceneEntityCfg
from agile.sim import BoxShapeCfg, ContactSensorCfg, RigidObjectCfg, SceneCfg, SimCfg
from agile.utils.config import ConfigError, configclass

TABLE_TOP_M = 0.4
OBJECT_EDGE_M = 0.06
ROBOT_A, ROBOT_B = SceneEntityCfg("robot_a"), SceneEntityCfg("robot_b")


def hanging_t1(y_m: float):
    cfg = t1_robot_cfg(t1_implicit_actuators())
    return dataclasses.replace(cfg, fixed_base=True, init_pos_m=(0.0, y_m, 1.2))


# -- scene: two T1s on stands, a table and a box on it
SCENE = SceneCfg(
    entities={"robot_a": hanging_t1(-0.6), "robot_b": hanging_t1(0.6),
              "table": RigidObjectCfg(shape=BoxShapeCfg(size_m=(0.5, 0.8, TABLE_TOP_M)), body_type="fixed",
                                      init_pos_m=(1.0, 0.0, TABLE_TOP_M / 2)),
              "object": RigidObjectCfg(shape=BoxShapeCfg(size_m=(OBJECT_EDGE_M,) * 3), mass_kg=0.2,
                                       init_pos_m=(1.0, 0.0, TABLE_TOP_M + OBJECT_EDGE_M / 2 + 0.01))},
    env_spacing_m=4.0,
    contact_sensors={"object_on_table": ContactSensorCfg(entity="object", filter_entity="table")})


@configclass
class ActionsCfg:
    robot_a_joints = mdp.JointPositionActionCfg(asset_name="robot_a", joint_names=[".*"])
    robot_b_joints = mdp.JointPositionActionCfg(asset_name="robot_b", joint_names=[".*"])


@configclass
class PolicyObsCfg(ObsGroup):
    robot_a_joint_pos = ObsTerm(func=mdp.joint_pos_rel, params={"asset_cfg": ROBOT_A})
    robot_b_joint_pos = ObsTerm(func=mdp.joint_pos_rel, params={"asset_cfg": ROBOT_B})
    object_lin_vel = ObsTerm(func=mdp.base_lin_vel, params={"asset_cfg": SceneEntityCfg("object")})


@configclass
class ObservationsCfg:
    policy = PolicyObsCfg()


@configclass
class RewardsCfg:
    robot_b_still = RewTerm(func=mdp.joint_vel_l2, weight=-1.0, params={"asset_cfg": ROBOT_B})


@configclass
class TerminationsCfg:
    time_out = DoneTerm(func=mdp.time_out, time_out=True)


@configclass
class EventsCfg:
    object_pose = EventTerm(func=mdp.reset_root_state_uniform, mode="reset",
                            params={"pose_range": {"x": (-0.1, 0.1), "y": (-0.1, 0.1), "yaw": (-3.14, 3.14)},
                                    "velocity_range": {}, "asset_cfg": SceneEntityCfg("object")})


@configclass
class TwoRobotsEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 2
    episode_length_s = 1.0
    scene = SCENE
    sim = SimCfg(physics_dt_s=0.005)
    actions = ActionsCfg()
    observations = ObservationsCfg()
    rewards = RewardsCfg()
    terminations = TerminationsCfg()
    events = EventsCfg()


DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


@pytest.mark.parametrize("device", DEVICES)
def test_two_robots_a_table_and_an_object_build_step_and_reset(device):
    env = ManagerBasedRLEnv(TwoRobotsEnvCfg(), device=device)
    a, b, obj = env.scene["robot_a"], env.scene["robot_b"], env.scene["object"]
    assert a.is_fixed_base and b.is_fixed_base and a.num_joints == b.num_joints == 23
    assert env.action_manager.total_action_dim == 46
    # world 0: robot A bends every joint by 0.3 rad; world 1: nothing moves; robot B is never driven
    action = torch.zeros(2, 46, device=env.device)
    action[0, :23] = 0.3
    for _ in range(30):
        obs, reward, terminated, truncated, extras = env.step(action)
    assert torch.allclose(a.joint_pos_target[0], a.default_joint_pos[0] + 0.3)
    assert torch.equal(b.joint_pos_target, b.default_joint_pos)
    assert (a.joint_pos[0] - a.joint_pos[1]).abs().mean() > 0.1  # A moved in world 0 only
    assert torch.allclose(b.joint_pos[0], b.joint_pos[1], atol=1e-4)  # B held its pose in both worlds
    # the fixed roots stayed at their stands, each at its env's origin
    assert torch.allclose(a.root_pos_w, env.env_origins + torch.tensor([0.0, -0.6, 1.2], device=env.device), atol=1e-5)
    # the object rests on the table: its weight on the table, a time-out reset put it back on it
    top = TABLE_TOP_M + OBJECT_EDGE_M / 2
    assert torch.allclose(obj.root_pos_w[:, 2], torch.full((2,), top, device=env.device), atol=5e-3)
    from_table = env.scene["object_on_table"].force_matrix_w[:, 0].sum(dim=1)
    assert from_table[:, 2].tolist() == pytest.approx([0.2 * 9.81] * 2, rel=0.05)
    assert obs["policy"].shape == (2, 23 + 23 + 3) and torch.isfinite(reward).all()


def test_a_reset_puts_every_entitys_bodies_where_its_root_was_written():
    # forward kinematics after a reset masks articulations, four per world here: a mask per world (the size of
    # the world count) updated world 0's entities only, and the object's body pose of world 1 kept its
    # template's, off its env (which a camera renders and body-frame terms read until the next physics step)
    env = ManagerBasedRLEnv(TwoRobotsEnvCfg(), device="cpu")
    env.reset()
    obj = env.scene["object"]
    assert torch.allclose(obj.body_pose_w[:, 0], obj.root_pose_w, atol=1e-6)
    for name in ("robot_a", "robot_b"):
        robot = env.scene[name]
        assert torch.allclose(robot.body_pose_w[:, 0, :3], robot.root_pos_w, atol=1e-6)


def test_a_term_naming_a_missing_entity_lists_the_scene():
    cfg = TwoRobotsEnvCfg()
    cfg.rewards.robot_b_still.params["asset_cfg"] = SceneEntityCfg("robot_c")
    with pytest.raises(ConfigError, match=r"robot_b_still.*'robot_c'.*\['object', 'robot_a', 'robot_b', 'table'\]"):
        ManagerBasedRLEnv(cfg, device="cpu")


def test_an_action_term_naming_a_missing_entity_lists_the_scene():
    cfg = TwoRobotsEnvCfg()
    cfg.actions.robot_b_joints.asset_name = "robot"
    with pytest.raises(ConfigError, match=r"robot_b_joints.*'robot'.*\['object', 'robot_a', 'robot_b', 'table'\]"):
        ManagerBasedRLEnv(cfg, device="cpu")
