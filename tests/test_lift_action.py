"""The stand-up lift (AGILE `LiftAction`) and its two curricula, with hand-computed values: the lift's force and
yaw torque on T1's head for a known height, episode time and yaw rate; its per-episode highest height; the
adaptive lift curriculum's EMA and decay; the terrain rows after standing time-outs and failures (CPU)."""

import math

import pytest
import torch
from fakes import FakeEnv

from agile.assets.booster_t1 import t1_robot_cfg
from agile.rl_env import ManagerBasedRLEnv, ManagerBasedRLEnvCfg, mdp
from agile.rl_env.managers import CurrTerm, DoneTerm, ObsGroup, ObsTerm
from agile.tasks.stand_up.mdp.curriculums import adaptive_lift_curriculum, terrain_levels_standing_at_timeout
from agile.sim import HeightScannerCfg, SceneCfg, SimCfg
from agile.sim.terrain import PyramidStairsTerrainCfg, TerrainGeneratorCfg
from agile.utils.config import configclass

SENSOR = "height_measurement_sensor"
# three rows of stairs up to a 1 m platform 0.2 m high, where each env spawns: the ground under T1 is not z=0
STAIRS = TerrainGeneratorCfg(size_m=4.0, num_rows=3, num_cols=1, border_width_m=1.0, horizontal_scale_m=0.1,
                             sub_terrains={"stairs": PyramidStairsTerrainCfg(
                                 step_height_range_m=(0.1, 0.1), step_width_m=0.5, platform_width_m=1.0,
                                 border_width_m=0.5)})


@configclass
class ActionsCfg:
    lift = mdp.LiftActionCfg()  # AGILE T1's values, on "H2" (the head)


@configclass
class PolicyObsCfg(ObsGroup):
    base_height = ObsTerm(func=mdp.base_height_from_sensor, params={"sensor_name": SENSOR})


@configclass
class ObservationsCfg:
    policy = PolicyObsCfg()


@configclass
class TerminationsCfg:
    time_out = DoneTerm(func=mdp.time_out, time_out=True)


@configclass
class CurriculumCfg:
    adaptive_lift = CurrTerm(func=adaptive_lift_curriculum, params={"lift_action_name": "lift"})
    terrain_levels = CurrTerm(func=terrain_levels_standing_at_timeout, params={"sensor_name": SENSOR})


@configclass
class LiftEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 2
    decimation = 4
    episode_length_s = 20.0
    scene = SceneCfg(entities={"robot": t1_robot_cfg()}, terrain=STAIRS, max_init_terrain_level=0,
                     height_scanners={SENSOR: HeightScannerCfg(entity="robot", body_name="Trunk")})
    sim = SimCfg(physics_dt_s=0.005)
    actions = ActionsCfg()
    observations = ObservationsCfg()
    terminations = TerminationsCfg()
    curriculum = CurriculumCfg()


@pytest.fixture(scope="module")
def env():
    env = ManagerBasedRLEnv(LiftEnvCfg(), device="cpu")
    yield env
    env.close()


def place(env, heights_m: list[float], yaw_rates_rad_s: list[float] | None = None,
          quat_xyzw: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)) -> None:
    """Each env's robot at its env origin's xy, its root `heights_m` above the terrain under the height scanner,
    turning at `yaw_rates_rad_s` about world z (upright by default); the scan refreshed as after an env step."""
    robot, scanner = env.scene["robot"], env.scene[SENSOR]
    everyone = torch.ones(env.num_envs, dtype=torch.bool)
    pose = robot.default_root_pose.clone()
    pose[:, :3] = env.env_origins
    pose[:, 3:7] = torch.tensor(quat_xyzw)
    velocity = torch.zeros(env.num_envs, 6)
    if yaw_rates_rad_s is not None:
        velocity[:, 5] = torch.tensor(yaw_rates_rad_s)
    for _ in range(2):  # the first pass finds the terrain under the root, the second sets the height above it
        robot.write_root_state(pose, velocity, everyone)
        env.sim.forward()
        env.scene.update()
        pose[:, 2] = scanner.hit_z_m.mean(dim=1) + torch.tensor(heights_m)


def lift_wrench(env) -> torch.Tensor:
    """(N, 6) the lift's force on the head and its yaw torque on the root (the trunk), after one env step's lift
    update and one physics step's wrench."""
    robot, lift = env.scene["robot"], env.action_manager.get_term("lift")
    head, trunk = robot.find_bodies("H2")[0][0], robot.find_bodies("Trunk")[0][0]
    robot.body_wrench_w[:, [head, trunk]] = 0.0
    lift.apply_actions()
    lift.apply_wrench()
    # the head is pulled up, not turned: a torque there would spin it about the neck's weak yaw joint
    assert not robot.body_wrench_w[:, head, 3:].any() and not robot.body_wrench_w[:, trunk, :3].any()
    return torch.cat((robot.body_wrench_w[:, head, :3], robot.body_wrench_w[:, trunk, 3:]), dim=1)


# -- the lift ------------------------------------------------------------------------------------------------

def test_lift_force_and_yaw_torque_for_a_known_height_time_and_yaw_rate(env):
    robot, lift = env.scene["robot"], env.action_manager.get_term("lift")
    assert env.action_manager.total_action_dim == 0 and lift.action_dim == 0  # the policy does not drive it
    assert env.scene[SENSOR].hit_z_m.mean().item() > 0.1  # on the platform: heights are above the terrain
    place(env, [0.3, 0.3], yaw_rates_rad_s=[0.5, -3.0])
    height_m = robot.root_pos_w[:, 2] - env.scene[SENSOR].hit_z_m.mean(dim=1)
    assert height_m.tolist() == pytest.approx([0.3, 0.3], abs=1e-5)
    # env 0 at 8 s: target (8 - 3) / 10 · 0.65 = 0.325 m, F = 5000 · 0.025 = 125 N, τ = -100 · 0.5 = -50 N·m
    # env 1 at 2 s: target 0 (before 3 s), so no force; τ = -100 · -3 = 300 N·m, clamped to 250 N·m
    env.episode_length_buf[:] = torch.tensor([400, 100])
    wrench = lift_wrench(env)
    expected = torch.tensor([[0.0, 0.0, 125.0, 0.0, 0.0, -50.0], [0.0, 0.0, 0.0, 0.0, 0.0, 250.0]])
    assert torch.allclose(wrench, expected, atol=0.05), wrench
    others = [b for b in range(robot.num_bodies) if robot.body_names[b] not in ("H2", "Trunk")]
    assert not robot.body_wrench_w[:, others].any()  # the head is lifted and the trunk damped, nothing else

    # at 14 s the target is 0.65 m: 5000 · 0.35 = 1750 N, clamped to 300 N; 0.8 m up, the lift never pulls down
    place(env, [0.3, 0.8], yaw_rates_rad_s=[0.5, -3.0])
    env.episode_length_buf[:] = 700
    wrench = lift_wrench(env)
    expected = torch.tensor([[0.0, 0.0, 300.0, 0.0, 0.0, -50.0], [0.0, 0.0, 0.0, 0.0, 0.0, 250.0]])
    assert torch.allclose(wrench, expected, atol=0.05), wrench

    # scale_forces scales the gains and the limits: k 1250, 75 N; d 25, 62.5 N·m (a 0-dim tensor or a float)
    lift.scale_forces(torch.tensor(0.25))
    assert lift.scale.shape == (1,) and lift.scale.item() == 0.25
    place(env, [0.62, 0.3], yaw_rates_rad_s=[0.5, -3.0])
    wrench = lift_wrench(env)
    expected = torch.tensor([[0.0, 0.0, 1250.0 * 0.03, 0.0, 0.0, -12.5], [0.0, 0.0, 75.0, 0.0, 0.0, 62.5]])
    assert torch.allclose(wrench, expected, atol=0.05), wrench
    lift.scale_forces(0.0)
    assert not lift_wrench(env).any()
    lift.scale_forces(1.0)
    env.reset()


def test_the_lift_acts_in_every_physics_step_of_an_env_step(env):
    robot, lift = env.scene["robot"], env.action_manager.get_term("lift")
    env.reset()
    assert not lift.max_heights_m.any()
    # T1 lying on its side in the air (no contact), its root 0.4 m up, at 13 s (target 0.65 m): 5000 · 0.25 =
    # 1250 N, clamped to 300 N on the head, for the 4 physics steps of the env step; env 0 turns about world z
    lying = (math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4))
    place(env, [0.4, 0.4], yaw_rates_rad_s=[1.0, 0.0], quat_xyzw=lying)
    env.episode_length_buf[:] = 650
    env.step(torch.zeros(2, 0))
    head = robot.find_bodies("H2")[0][0]
    head_wrench = robot.body_wrench_w[:, head]
    trunk_wrench = robot.body_wrench_w[:, robot.find_bodies("Trunk")[0][0]]
    assert head_wrench[:, 2].tolist() == pytest.approx([300.0, 300.0])
    # yaw damping against the turn, on the root: 100 N·m·s/rad brakes the lying T1's 1 rad/s within the env step,
    # and the last physics step's torque is -100 times what is left
    yaw_rate = robot.root_ang_vel_w[0, 2].item()
    assert 0.0 < yaw_rate < 0.5 and trunk_wrench[0, 5].item() < -1.0 and abs(trunk_wrench[1, 5]) < 1.0
    # env 1's momentum: (300 N - m·g) · 0.02 s instead of the fall's -m·g · 0.02 s
    mass_kg = robot.body_mass[1].sum()
    com_vel_z = (robot.body_mass[1] * robot.body_vel_w[1, :, 2]).sum() / mass_kg
    assert com_vel_z.item() == pytest.approx(((300.0 - mass_kg * 9.81) / mass_kg * 0.02).item(), abs=1e-3)
    assert (lift.max_heights_m >= 0.4 - 1e-5).all() and (lift.max_heights_m < 0.41).all()


def test_max_heights_follow_the_robot_and_restart_each_episode(env):
    lift = env.action_manager.get_term("lift")
    # the maximum holds while the robot sinks and rises with it
    lift.reset(torch.ones(2, dtype=torch.bool))
    for heights, expected in (([0.4, 0.2], [0.4, 0.2]), ([0.3, 0.5], [0.4, 0.5]), ([0.45, 0.1], [0.45, 0.5])):
        place(env, heights)
        lift_wrench(env)
        assert lift.max_heights_m.tolist() == pytest.approx(expected, abs=1e-5)
    lift.reset(torch.tensor([True, False]))  # env 0 starts a new episode
    assert lift.max_heights_m.tolist() == pytest.approx([0.0, 0.5], abs=1e-5)
    env.reset()


# -- adaptive lift curriculum --------------------------------------------------------------------------------

class _Lift:
    def __init__(self, max_heights_m):
        self.max_heights_m = torch.tensor(max_heights_m)
        self.scale = None

    def scale_forces(self, scale):
        self.scale = scale.clone()


class _Terms:
    def __init__(self, **terms):
        self.terms = terms

    def get_term(self, name):
        return self.terms[name]


def _curriculum(lift, **params):
    env = FakeEnv(num_envs=lift.max_heights_m.shape[0])
    env.action_manager = _Terms(lift=lift)
    params = {"lift_action_name": "lift", **params}
    return env, adaptive_lift_curriculum(CurrTerm(func=adaptive_lift_curriculum, params=params), env), params


def test_adaptive_lift_decays_while_most_episodes_stand_and_never_rises():
    lift = _Lift([0.6, 0.6, 0.6, 0.3])  # 3 of 4 episodes reached 0.55 m
    env, term, params = _curriculum(lift, ema_alpha=0.5, decay=0.5, disable_below=0.2)
    everyone, nobody = torch.ones(4, dtype=torch.bool), torch.zeros(4, dtype=torch.bool)
    # EMA ← 0.5 · EMA + 0.5 · 0.75 from 0: 0.375, 0.5625, 0.65625 (≤ 0.7: no decay), 0.703125 (> 0.7: halved)
    for ema, scale in ((0.375, 1.0), (0.5625, 1.0), (0.65625, 1.0), (0.703125, 0.5), (0.7265625, 0.25)):
        value = term(env, everyone, **params)
        assert term.standing_share_ema.item() == pytest.approx(ema) and value.item() == pytest.approx(scale)
        assert lift.scale.item() == pytest.approx(scale)
    # no resetting env: nothing changes
    assert term(env, nobody, **params).item() == pytest.approx(0.25)
    assert term.standing_share_ema.item() == pytest.approx(0.7265625)
    # only the resetting envs count: env 3 alone ended, below standing height: EMA 0.363..., the scale stays
    assert term(env, torch.tensor([False, False, False, True]), **params).item() == pytest.approx(0.25)
    assert term.standing_share_ema.item() == pytest.approx(0.36328125)
    lift.max_heights_m.fill_(0.3)
    for _ in range(20):  # everyone falls: the scale never rises (only_decrease)
        assert term(env, everyone, **params).item() == pytest.approx(0.25)
    ema = term.standing_share_ema.item()
    assert ema < 1e-6
    lift.max_heights_m.fill_(0.7)  # everyone stands: EMA ≈ 0.5 (no decay), then ≈ 0.75 (decay)
    assert term(env, everyone, **params).item() == pytest.approx(0.25)
    assert term.standing_share_ema.item() == pytest.approx(0.5 * ema + 0.5)
    # the decay goes below disable_below (0.125 < 0.2): the lift is switched off, and stays off
    assert term(env, everyone, **params).item() == 0.0 and lift.scale.item() == 0.0
    lift.max_heights_m.fill_(0.0)
    params["only_decrease"] = False
    for _ in range(100):
        assert term(env, everyone, **params).item() == 0.0


def test_adaptive_lift_with_agiles_settings():
    # every episode stands: EMA = 1 - 0.99^k passes 0.7 at k = 120 (0.99^120 = 0.2994); then ×(1 - 1e-4) per step
    lift = _Lift([0.6, 0.6])
    env, term, params = _curriculum(lift)
    everyone = torch.ones(2, dtype=torch.bool)
    assert math.ceil(math.log(0.3) / math.log(0.99)) == 120
    for k in range(1, 131):
        value = term(env, everyone, **params)
        assert term.standing_share_ema.item() == pytest.approx(1.0 - 0.99 ** k, rel=1e-5)
        assert value.item() == pytest.approx(0.9999 ** max(0, k - 119), rel=1e-5), k


def test_adaptive_lift_can_rise_again_unless_only_decrease():
    lift = _Lift([0.6, 0.6])
    env, term, params = _curriculum(lift, ema_alpha=1.0, decay=0.1, only_decrease=False)
    everyone = torch.ones(2, dtype=torch.bool)
    assert term(env, everyone, **params).item() == pytest.approx(0.9)
    assert term(env, everyone, **params).item() == pytest.approx(0.81)
    lift.max_heights_m[:] = torch.tensor([0.6, 0.3])  # EMA 0.5: rises by 10 %, to at most 1
    assert term(env, everyone, **params).item() == pytest.approx(0.891)
    assert term(env, everyone, **params).item() == pytest.approx(0.9801)
    assert term(env, everyone, **params).item() == pytest.approx(1.0)


def test_adaptive_lift_drives_the_lift_of_the_env(env):
    lift = env.action_manager.get_term("lift")
    assert env.curriculum_manager.active_terms == ["adaptive_lift", "terrain_levels"]
    term = env.curriculum_manager.funcs["adaptive_lift"]  # built by the manager, on the env's lift
    params = {"lift_action_name": "lift", "ema_alpha": 1.0, "decay": 0.5}
    lift.max_heights_m[:] = 0.6
    assert term(env, torch.ones(2, dtype=torch.bool), **params).item() == pytest.approx(0.5)
    assert lift.scale.tolist() == [0.5]
    term.scale.fill_(1.0)
    term.standing_share_ema.zero_()
    lift.scale_forces(1.0)
    env.reset()


# -- terrain levels ------------------------------------------------------------------------------------------

def test_terrain_levels_move_up_after_standing_time_outs_and_down_after_failures(env):
    sim = env.sim
    params = {"min_height_m": 0.52, "sensor_name": SENSOR, "n_successes": 5, "n_failures": 5}
    term = terrain_levels_standing_at_timeout(
        CurrTerm(func=terrain_levels_standing_at_timeout, params=params), env)
    everyone, nobody = torch.ones(2, dtype=torch.bool), torch.zeros(2, dtype=torch.bool)
    sim.terrain_levels.fill_(1)
    sim.update_terrain_levels(nobody, nobody)

    def episode(heights_m: list[float], timed_out: list[bool], ending=everyone) -> torch.Tensor:
        place(env, heights_m)
        env.termination_manager.time_outs[:] = torch.tensor(timed_out)
        return term(env, ending, **params)

    # env 0 stands at the time-out (a success), env 1 is down at the time-out (a failure)
    for _ in range(4):
        assert episode([0.6, 0.4], [True, True]).item() == pytest.approx(1.0)
        episode([0.6, 0.4], [True, True], ending=nobody)  # a step where no episode ends counts nothing
    assert term.outcomes.num_successes.tolist() == [4, 0] and term.outcomes.num_failures.tolist() == [0, 4]
    assert episode([0.6, 0.4], [True, True]).item() == pytest.approx(1.0)  # rows 2 and 0
    assert sim.terrain_levels.tolist() == [2, 0]
    assert not term.outcomes.num_successes.any() and not term.outcomes.num_failures.any()  # a move clears both counts
    assert torch.equal(sim.env_origins, sim.terrain_origins_m[sim.terrain_levels, sim.terrain_types])
    # env 0 stands but its episode ended early (not a time-out): a failure; env 1 now stands at the time-out
    for _ in range(4):
        episode([0.6, 0.6], [False, True])
    assert sim.terrain_levels.tolist() == [2, 0]
    episode([0.6, 0.6], [False, True])
    assert sim.terrain_levels.tolist() == [1, 1]
    env.termination_manager.time_outs.zero_()
    env.reset()
