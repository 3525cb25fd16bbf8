"""Contact sensor on real physics (T1, CPU, two worlds) and the contact terms on hand-made sensor data."""

import pytest
import torch
from fakes import FakeEnv

from agile.assets.booster_t1 import t1_implicit_actuators, t1_robot_cfg
from agile.rl_env import ManagerBasedRLEnv, mdp
from agile.rl_env.managers import SceneEntityCfg
from agile.sim import ContactSensorCfg, SimCfg, Simulation
from scenes import robot_sim
from agile.sim.names import resolve_names
from agile.tasks.velocity.g1.velocity_history_env_cfg import G1VelocityHistoryEnvCfg
from agile.tasks.velocity.t1.velocity_env_cfg import T1VelocityEnvCfg

GRAVITY_MPS2 = 9.81
PHYSICS_STEPS = 4
STEP_DT_S = 0.02
DROP_HEIGHT_M = 0.4
SENSED = ["Trunk", ".*_foot_link"]


def t1_sim(num_envs: int, **sensor_kwargs) -> Simulation:
    return robot_sim(t1_robot_cfg(t1_implicit_actuators()), num_envs, STEP_DT_S, sim=SimCfg(physics_dt_s=STEP_DT_S / PHYSICS_STEPS),
                     contact_sensor=ContactSensorCfg(**sensor_kwargs))


@pytest.fixture(scope="module")
def stand_and_drop():
    """World 0 starts standing, world 1 starts DROP_HEIGHT_M higher; 25 env steps of sensor readings."""
    sim = t1_sim(2, body_names=SENSED)
    robot = sim.scene["robot"]
    raise_world_1 = torch.tensor([False, True])
    pose = robot.root_pose_w.clone()
    pose[:, 2] += DROP_HEIGHT_M
    robot.write_root_state(pose, torch.zeros_like(robot.root_com_vel_w), raise_world_1)
    sim.forward(raise_world_1)
    sensor = sim.scene["contact_forces"]
    trace = []
    for _ in range(25):
        sim.step(PHYSICS_STEPS)
        trace.append({"force": sensor.net_forces_w.clone(), "air": sensor.current_air_time_s.clone(),
                      "last_air": sensor.last_air_time_s.clone(),
                      "first_contact": sensor.compute_first_contact(STEP_DT_S).clone()})
    return sim, trace


def test_standing_robot_has_both_feet_down_and_carries_its_weight(stand_and_drop):
    sim, trace = stand_and_drop
    feet, _ = sim.scene["contact_forces"].find_bodies(".*_foot_link")
    trunk, _ = sim.scene["contact_forces"].find_bodies("Trunk")
    weight_n = sim.scene["robot"].body_mass[0].sum().item() * GRAVITY_MPS2
    for step in trace[10:20]:  # settled, before the untrained robot starts to tip over
        force = step["force"][0]
        assert (force[feet].norm(dim=-1) > 1.0).all()
        assert force[trunk].norm() == 0.0
        assert force[:, 2].sum().item() == pytest.approx(weight_n, rel=0.1)


def test_dropped_robot_is_airborne_then_lands_with_first_contact(stand_and_drop):
    sim, trace = stand_and_drop
    feet, _ = sim.scene["contact_forces"].find_bodies(".*_foot_link")
    in_contact = [bool((s["force"][1, feet].norm(dim=-1) > 1.0).any()) for s in trace]
    touchdown = in_contact.index(True)
    # free fall of 0.4 m takes about 0.29 s
    assert 0.2 < touchdown * STEP_DT_S < 0.4
    for k in range(touchdown):
        assert trace[k]["air"][1, feet] == pytest.approx([(k + 1) * STEP_DT_S] * 2, abs=1e-5)
        assert not trace[k]["first_contact"][1, feet].any()
    landed = trace[touchdown]
    landed_feet = [f for f in feet if landed["force"][1, f].norm() > 1.0]
    for f in landed_feet:
        assert landed["air"][1, f] == 0.0
        assert landed["first_contact"][1, f]
        # the flight lasted from the start to a physics step within this env step
        assert touchdown * STEP_DT_S < landed["last_air"][1, f] <= (touchdown + 1) * STEP_DT_S + 1e-5
    assert not trace[touchdown + 2]["first_contact"][1, landed_feet].any()


def test_history_holds_the_previous_physics_steps_newest_first():
    sim = t1_sim(1, body_names=".*_foot_link", history_length=3)
    sensor = sim.scene["contact_forces"]
    newest = []
    for _ in range(12):
        sim.step(1)
        newest.append(sensor.net_forces_w[0].clone())
        assert torch.equal(sensor.net_forces_w, sensor.net_forces_w_history[:, 0])
    history = sensor.net_forces_w_history[0]
    assert newest[-1].norm() > 0.0
    for age in range(3):
        assert torch.equal(history[age], newest[-1 - age])


def test_reset_clears_only_the_masked_worlds(stand_and_drop):
    sim, _ = stand_and_drop
    sensor = sim.scene["contact_forces"]
    sim.step(PHYSICS_STEPS)
    kept = [t.clone()[1] for t in (sensor.net_forces_w_history, sensor.lin_vel_w_history, sensor.current_contact_time_s,
                                   sensor.last_air_time_s)]
    assert kept[0].norm() > 0.0 and kept[2].max() > 0.0
    sim.reset_worlds(torch.tensor([True, False]))
    for t in (sensor.net_forces_w_history, sensor.lin_vel_w_history, sensor.current_air_time_s,
              sensor.current_contact_time_s, sensor.last_air_time_s, sensor.last_contact_time_s):
        assert (t[0] == 0.0).all()
    for before, t in zip(kept, (sensor.net_forces_w_history, sensor.lin_vel_w_history, sensor.current_contact_time_s,
                                sensor.last_air_time_s)):
        assert torch.equal(t[1], before)


def test_body_regex_matching_nothing_lists_the_bodies():
    with pytest.raises(ValueError, match=r"scene.contact_sensors.contact_forces: .*'.*_hoof' matches no body of 'robot'.*left_foot_link"):
        t1_sim(1, body_names=".*_hoof")


def test_air_time_needs_tracking():
    sim = t1_sim(1, body_names=".*_foot_link", track_air_time=False)
    with pytest.raises(RuntimeError, match="track_air_time"):
        sim.scene["contact_forces"].compute_first_contact(STEP_DT_S)


@pytest.mark.parametrize("task_cfg", [T1VelocityEnvCfg, G1VelocityHistoryEnvCfg])
def test_task_contact_terms_reach_the_sensor_and_env_reset_clears_it(task_cfg):
    env = ManagerBasedRLEnv(task_cfg(num_envs=2), device="cpu")
    sensor = env.scene["contact_forces"]
    feet = env.reward_manager.get_term_cfg("feet_slip").params["sensor_cfg"].body_ids
    action = torch.zeros(2, env.action_manager.total_action_dim)
    for _ in range(10):
        env.step(action)
    assert (sensor.net_forces_w[:, feet].norm(dim=-1) > 1.0).all()
    assert {"feet_slip", "root_acc"} <= set(env.reward_manager.active_terms)
    assert "illegal_ground_contact" in env.termination_manager.active_terms
    env.reset()
    assert (sensor.net_forces_w_history == 0.0).all() and (sensor.current_contact_time_s == 0.0).all()


# -- terms on hand-made sensor data --------------------------------------------------------------

class FakeContactSensor:
    """The ContactSensor's readings as plain tensors: bodies (base, foot_l, foot_r), history of 3."""

    def __init__(self, num_envs: int, body_names=("base", "foot_l", "foot_r"), history_length: int = 3):
        self.body_names = list(body_names)
        self.num_bodies = len(body_names)
        shape = (num_envs, history_length, self.num_bodies, 3)
        self.net_forces_w_history = torch.zeros(shape)
        self.lin_vel_w_history = torch.zeros(shape)
        self.current_air_time_s = torch.zeros(num_envs, self.num_bodies)
        self.current_contact_time_s = torch.zeros(num_envs, self.num_bodies)
        self.last_air_time_s = torch.zeros(num_envs, self.num_bodies)
        self.force_matrix_w = None  # no filter entity: net forces only, as a ContactSensor without one

    @property
    def net_forces_w(self):
        return self.net_forces_w_history[:, 0]

    def find_bodies(self, exprs, preserve_order=False):
        return resolve_names(exprs, self.body_names, "body", preserve_order)

    def compute_first_contact(self, dt_s):
        return (self.current_contact_time_s > 0.0) & (self.current_contact_time_s <= dt_s)


class _Commands:
    def __init__(self, command):
        self.command = command

    def get_command(self, name):
        return self.command


def contact_env(num_envs: int) -> FakeEnv:
    env = FakeEnv(num_envs=num_envs)
    env.scene["contact_forces"] = FakeContactSensor(num_envs)
    env.step_dt = STEP_DT_S
    return env


def _sensor(env, body_names="foot_.*"):
    cfg = SceneEntityCfg("contact_forces", body_names=body_names)
    cfg.resolve(env)
    return cfg


def _robot(env, body_names="foot_.*"):
    cfg = SceneEntityCfg("robot", body_names=body_names)
    cfg.resolve(env)
    return cfg


def test_undesired_contacts_counts_bodies_over_threshold_in_any_recent_step():
    env = contact_env(2)
    forces = env.scene["contact_forces"].net_forces_w_history
    forces[0, 2, 0] = torch.tensor([0.0, 0.0, 5.0])  # base, oldest step
    forces[0, 0, 1] = torch.tensor([3.0, 4.0, 0.0])  # foot_l, |F| = 5
    forces[1, 0, 0] = torch.tensor([0.0, 0.0, 0.5])  # below the threshold
    value = mdp.undesired_contacts(env, force_threshold_n=1.0, sensor_cfg=_sensor(env, ".*"))
    assert value.tolist() == [2.0, 0.0]


def test_feet_slip_sums_horizontal_speed_of_feet_in_contact():
    env = contact_env(1)
    env.robot.body_vel_w = torch.zeros(1, 3, 6)
    env.robot.body_vel_w[0, 1, :3] = torch.tensor([3.0, 4.0, 9.0])  # foot_l in contact: 5 m/s horizontally
    env.robot.body_vel_w[0, 2, :3] = torch.tensor([1.0, 0.0, 0.0])  # foot_r in the air
    env.scene["contact_forces"].net_forces_w_history[0, 1, 1, 2] = 50.0
    value = mdp.feet_slip(env, sensor_cfg=_sensor(env), asset_cfg=_robot(env))
    assert value.item() == pytest.approx(5.0)


def test_jumping_is_one_only_when_no_foot_pushes():
    env = contact_env(3)
    forces = env.scene["contact_forces"].net_forces_w_history
    forces[1, 0, 2, 2] = 20.0  # one foot down
    forces[2, 0, 1, 2] = 5.0  # light touch, below 10 N
    forces[2, 1, 2, 2] = 50.0  # an older step does not count
    value = mdp.jumping(env, force_threshold_n=10.0, sensor_cfg=_sensor(env))
    assert value.tolist() == [1.0, 0.0, 1.0]


def test_feet_stumble_is_the_largest_horizontal_force_over_the_threshold():
    env = contact_env(2)
    forces = env.scene["contact_forces"].net_forces_w_history
    forces[0, 1, 2] = torch.tensor([6.0, 8.0, 100.0])  # 10 N horizontally
    forces[0, 0, 1] = torch.tensor([3.0, 0.0, 0.0])
    forces[1, 0, 1] = torch.tensor([0.5, 0.0, 300.0])
    value = mdp.feet_stumble(env, sensor_cfg=_sensor(env), force_threshold_n=1.0)
    assert value.tolist() == pytest.approx([9.0, 0.0])


def test_impact_velocity_uses_the_speed_before_touchdown():
    env = contact_env(1)
    sensor = env.scene["contact_forces"]
    sensor.net_forces_w_history[0, 0, 1, 2] = 200.0  # foot_l just landed
    sensor.lin_vel_w_history[0, 0, 1] = torch.tensor([0.0, 0.0, -0.1])
    sensor.lin_vel_w_history[0, 2, 1] = torch.tensor([0.0, 0.6, -0.8])  # 1 m/s two steps earlier
    sensor.lin_vel_w_history[0, 0, 2] = torch.tensor([0.0, 0.0, -3.0])  # foot_r still in the air
    value = mdp.impact_velocity_l1(env, sensor_cfg=_sensor(env), force_threshold_n=10.0)
    assert value.item() == pytest.approx(1.0)


def test_equal_foot_force():
    env = contact_env(3)
    forces = env.scene["contact_forces"].net_forces_w_history
    forces[0, 0, 1:, 2] = 150.0
    forces[1, 0, 1, 2] = 300.0
    forces[2, 0, 1, 2], forces[2, 0, 2, 2] = 100.0, 200.0
    value = mdp.equal_foot_force(env, sensor_cfg=_sensor(env))
    # env 2: mean 150, mean |deviation| 50 -> 1 - 1/3
    assert value.tolist() == pytest.approx([1.0, 0.0, 2.0 / 3.0], abs=1e-5)


def test_feet_air_time_rewards_touchdowns_after_long_flights_while_moving():
    env = contact_env(3)
    env.command_manager = _Commands(torch.tensor([[0.5, 0.0, 0.0], [0.5, 0.0, 0.0], [0.05, 0.0, 0.0]]))
    sensor = env.scene["contact_forces"]
    sensor.current_contact_time_s[:, 1] = 0.01  # foot_l touched down in this step ...
    sensor.last_air_time_s[:, 1] = 0.7  # ... after 0.7 s in the air
    sensor.current_contact_time_s[1, 1] = 0.3  # env 1: that touchdown was long ago
    value = mdp.feet_air_time(env, command_name="v", threshold_s=0.5, sensor_cfg=_sensor(env))
    assert value.tolist() == pytest.approx([0.2, 0.0, 0.0])  # env 2: command below 0.1 m/s


def test_feet_air_time_positive_biped_rewards_single_stance():
    env = contact_env(3)
    env.command_manager = _Commands(torch.tensor([[0.5, 0.0, 0.0]] * 3))
    sensor = env.scene["contact_forces"]
    sensor.current_contact_time_s[0, 1], sensor.current_air_time_s[0, 2] = 0.3, 0.2  # single stance
    sensor.current_contact_time_s[1, 1], sensor.current_air_time_s[1, 2] = 0.6, 0.7  # capped
    sensor.current_contact_time_s[2, 1:] = 0.3  # double stance
    value = mdp.feet_air_time_positive_biped(env, command_name="v", threshold_s=0.4, sensor_cfg=_sensor(env))
    assert value.tolist() == pytest.approx([0.2, 0.4, 0.0])


def test_illegal_ground_contact_needs_force_and_low_body():
    env = contact_env(3)
    forces = env.scene["contact_forces"].net_forces_w_history
    forces[0, 1, 0, 2] = 30.0
    forces[1, 0, 0, 2] = 30.0
    forces[2, 0, 0, 2] = 10.0
    env.robot.body_pose_w[:, 0, 2] = torch.tensor([0.3, 0.6, 0.3])  # env 1 is still tall
    value = mdp.illegal_ground_contact(env, force_threshold_n=20.0, min_height_m=0.45,
                                       sensor_cfg=_sensor(env, "base"), asset_cfg=_robot(env, "base"))
    assert value.tolist() == [True, False, False]


def test_contact_force_norm_observation():
    env = contact_env(1)
    env.scene["contact_forces"].net_forces_w_history[0, 0, 2] = torch.tensor([0.0, 3.0, 4.0])
    value = mdp.contact_force_norm(env, sensor_cfg=_sensor(env))
    assert value.shape == (1, 2) and value[0].tolist() == pytest.approx([0.0, 5.0])
