"""Terms of the stand-up task (AGILE StandUp-T1) with hand-computed values: the standing gate, the gated
rewards, `is_terminated_term` and the `no_height_progress` termination over scripted height sequences."""

import math

import pytest
import torch
from fakes import FakeEnv

from agile.rl_env.managers import DoneTerm, SceneEntityCfg, TerminationManager
from agile.rl_env.mdp.rewards import is_terminated_term
from agile.tasks.stand_up.mdp import rewards as stand_up
from agile.rl_env.mdp.terminations import no_height_progress
from agile.utils.config import ConfigError, configclass
from agile.utils.math import quat_from_euler_xyz

MIN_HEIGHT_M = 0.5


def _entity(env, **kwargs):
    cfg = SceneEntityCfg("robot", **kwargs)
    cfg.resolve(env)
    return cfg


class _Scanner:
    """A height scanner whose rays hit the terrain at `hit_z_m` (N, R)."""

    def __init__(self, hit_z_m):
        self.hit_z_m = hit_z_m


def _env_one_up_one_down():
    """Env 0 stands (root 0.7 m above z=0), env 1 lies (0.2 m)."""
    env = FakeEnv(num_envs=2)
    env.robot.root_pos_w[:, 2] = torch.tensor([0.7, 0.2])
    return env


# -- the standing gate -------------------------------------------------------------------------------------

def test_standing_above_z0_and_above_the_terrain():
    env = _env_one_up_one_down()
    assert stand_up.standing(env, min_height_m=MIN_HEIGHT_M).tolist() == [True, False]
    # terrain at 0.3 m under env 0 (0.4 m above it: down) and at -0.4 m under env 1 (0.6 m above it: up)
    env.scene["scan"] = _Scanner(torch.tensor([[0.2, 0.4], [-0.4, -0.4]]))
    assert stand_up.standing(env, min_height_m=MIN_HEIGHT_M, sensor_name="scan").tolist() == [False, True]
    assert stand_up.standing(env, min_height_m=0.7).tolist() == [False, False]  # strictly above


# -- gated rewards -----------------------------------------------------------------------------------------

def test_joint_deviation_if_standing_l1_and_l2():
    env = _env_one_up_one_down()
    env.robot.joint_pos[:] = torch.tensor([0.5, -0.2, 0.3])
    env.robot.default_joint_pos[:] = torch.tensor([0.1, 0.1, 0.0])
    joints = _entity(env, joint_names=["a", "b"])
    l1 = stand_up.joint_deviation_if_standing(env, MIN_HEIGHT_M, joints)
    assert l1.tolist() == pytest.approx([0.4 + 0.3, 0.0])
    l2 = stand_up.joint_deviation_if_standing(env, MIN_HEIGHT_M, joints, norm="l2")
    assert l2.tolist() == pytest.approx([0.16 + 0.09, 0.0])
    everything = stand_up.joint_deviation_if_standing(env, MIN_HEIGHT_M, _entity(env, joint_names=".*"))
    assert everything.tolist() == pytest.approx([0.4 + 0.3 + 0.3, 0.0])


def test_joint_deviation_if_standing_rejects_an_unknown_norm():
    env = _env_one_up_one_down()
    with pytest.raises(ValueError, match=r"norm must be one of \('l1', 'l2'\), got 'linf'"):
        stand_up.joint_deviation_if_standing(env, MIN_HEIGHT_M, _entity(env), norm="linf")


def test_moving_if_standing():
    env = _env_one_up_one_down()
    env.robot.root_lin_vel_b[:] = torch.tensor([0.3, -0.4, 0.0])
    env.robot.root_ang_vel_b[:] = torch.tensor([1.0, 0.0, -2.0])
    value = stand_up.moving_if_standing(env, MIN_HEIGHT_M, asset_cfg=_entity(env))
    assert value.tolist() == pytest.approx([0.09 + 0.16 + 1.0 + 4.0, 0.0])


def test_feet_distance_from_ref_if_standing():
    env = _env_one_up_one_down()
    env.robot.heading_w[:] = math.pi / 2  # facing +y: the lateral axis is world -x
    env.robot.body_pose_w[:, 1, :3] = torch.tensor([-0.15, 0.0, 0.0])  # left foot
    env.robot.body_pose_w[:, 2, :3] = torch.tensor([0.15, 0.1, 0.0])  # right foot
    feet = _entity(env, body_names=["foot_l", "foot_r"])
    value = stand_up.feet_distance_from_ref_if_standing(env, MIN_HEIGHT_M, ref_distance_m=0.2, asset_cfg=feet)
    assert value.tolist() == pytest.approx([0.1, 0.0], abs=1e-6)  # |0.3 - 0.2| while up


def test_feet_yaw_mean_vs_base_if_standing():
    env = _env_one_up_one_down()
    zero = torch.tensor(0.0)
    env.robot.body_pose_w[:, 0, 3:7] = quat_from_euler_xyz(zero, zero, torch.tensor(0.5))  # base
    env.robot.body_pose_w[:, 1, 3:7] = quat_from_euler_xyz(zero, zero, torch.tensor(0.8))  # toes out by 0.3
    env.robot.body_pose_w[:, 2, 3:7] = quat_from_euler_xyz(zero, zero, torch.tensor(0.4))  # toes in by 0.1
    value = stand_up.feet_yaw_mean_vs_base_if_standing(
        env, MIN_HEIGHT_M, feet_asset_cfg=_entity(env, body_names=["foot_l", "foot_r"]),
        base_body_cfg=_entity(env, body_names=["base"]))
    assert value.tolist() == pytest.approx([0.09 + 0.01, 0.0], abs=1e-5)


# -- is_terminated_term ------------------------------------------------------------------------------------

def _by_env(env, which: int):
    return torch.arange(env.num_envs) == which


@configclass
class _Terminations:
    time_out = DoneTerm(func=_by_env, params={"which": 0}, time_out=True)
    fell = DoneTerm(func=_by_env, params={"which": 1})
    stuck = DoneTerm(func=_by_env, params={"which": 2})


def test_is_terminated_term_reads_the_named_terms():
    env = FakeEnv(num_envs=4)
    env.termination_manager = TerminationManager(_Terminations(), env)
    env.termination_manager.compute()
    assert is_terminated_term(env, "stuck").tolist() == [0.0, 0.0, 1.0, 0.0]
    assert is_terminated_term(env, ["fell", "stuck"]).tolist() == [0.0, 1.0, 1.0, 0.0]
    assert is_terminated_term(env, ["time_out"]).tolist() == [1.0, 0.0, 0.0, 0.0]


def test_is_terminated_term_rejects_unknown_names():
    env = FakeEnv(num_envs=4)
    env.termination_manager = TerminationManager(_Terminations(), env)
    env.termination_manager.compute()
    with pytest.raises(ValueError, match=r"unknown \['falen'\].*\['time_out', 'fell', 'stuck'\]"):
        is_terminated_term(env, ["fell", "falen"])
    with pytest.raises(ValueError, match="unknown"):
        is_terminated_term(env, [])


# -- no_height_progress ------------------------------------------------------------------------------------

STEP_DT_S = 0.02
WINDOW_S = 0.1  # 5 env steps
PARAMS = {"standing_height_m": 0.6, "min_height_gain_m": 0.2, "time_window_s": WINDOW_S}


def _progress_env(num_envs: int):
    env = FakeEnv(num_envs=num_envs)
    env.step_dt = STEP_DT_S
    term = no_height_progress(DoneTerm(func=no_height_progress, params=dict(PARAMS)), env)
    return env, term


def _run(env, term, heights_m: list[list[float]]) -> list[list[bool]]:
    """One env step per row of heights (one per env): advance the episode clock, set the root heights, call."""
    dones = []
    for row in heights_m:
        env.episode_length_buf += 1
        env.robot.root_pos_w[:, 2] = torch.tensor(row)
        dones.append(term(env, **PARAMS).tolist())
    return dones


def test_no_height_progress_over_scripted_heights():
    env, term = _progress_env(num_envs=3)
    # env 0 rises 0.25 m then sinks back: it rose enough, never ends
    # env 1 creeps up 0.15 m only and lies: ends exactly when the 5-step window is over
    # env 2 starts standing (0.7 m, above 0.6) and stays up without rising: never ends
    heights = [[0.20, 0.20, 0.70],
               [0.30, 0.25, 0.70],
               [0.45, 0.30, 0.71],
               [0.40, 0.35, 0.69],
               [0.30, 0.35, 0.70],  # step 5: the window is over
               [0.20, 0.30, 0.70],
               [0.20, 0.30, 0.70]]
    dones = _run(env, term, heights)
    assert [d[0] for d in dones] == [False] * 7
    assert [d[1] for d in dones] == [False, False, False, False, True, True, True]
    assert [d[2] for d in dones] == [False] * 7


def test_no_height_progress_restarts_with_each_episode():
    env, term = _progress_env(num_envs=2)
    dones = _run(env, term, [[0.2, 0.2]] * 5)
    assert dones[-1] == [True, True]
    # env 0 resets (as the env does: terms first, the clock after); its new episode starts at 0.5 m and does not
    # rise, env 1 keeps lying
    reset = torch.tensor([True, False])
    term.reset(reset)
    env.episode_length_buf.masked_fill_(reset, 0)
    dones = _run(env, term, [[0.5, 0.2], [0.6, 0.2], [0.65, 0.2], [0.55, 0.2], [0.5, 0.2]])
    assert [d[0] for d in dones] == [False, False, False, False, True]  # 0.15 m gain in its own window
    assert all(d[1] for d in dones)


def test_no_height_progress_is_built_by_the_termination_manager():
    @configclass
    class Terms:
        stuck = DoneTerm(func=no_height_progress, params=dict(PARAMS))

    env = FakeEnv(num_envs=2)
    env.step_dt = STEP_DT_S
    manager = TerminationManager(Terms(), env)
    for _ in range(5):
        env.episode_length_buf += 1
        manager.compute()
    assert manager.term_dones["stuck"].tolist() == [True, True]  # lying at z=0 the whole window

    @configclass
    class Bad:
        stuck = DoneTerm(func=no_height_progress, params={**PARAMS, "time_window_s": 0.0})

    with pytest.raises(ConfigError, match="time_window_s must be positive"):
        TerminationManager(Bad(), env)

    @configclass
    class Missing:
        stuck = DoneTerm(func=no_height_progress, params={"min_height_gain_m": 0.2})

    with pytest.raises(ConfigError, match="standing_height_m"):
        TerminationManager(Missing(), env)
