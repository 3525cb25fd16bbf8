"""The scene of many entities: rigid objects on real physics, filtered contact forces, masked resets, bad input
(CPU, two worlds)."""

import math

import pytest
import torch

from agile.rl_env import mdp
from agile.rl_env.managers import SceneEntityCfg
from agile.sim import (GROUND, BoxShapeCfg, ContactSensorCfg, MeshFileShapeCfg, ModelFileShapeCfg, RigidObjectCfg,
                       SceneCfg, SimCfg, SphereShapeCfg, Simulation)
from agile.utils.config import ConfigError

GRAVITY_MPS2 = 9.81
PHYSICS_DT_S = 0.005
BOX_EDGE_M = 0.1
NUM_ENVS = 2


def make_sim(entities: dict, gravity_mps2: float = -GRAVITY_MPS2, **scene_fields) -> Simulation:
    scene = SceneCfg(entities=entities, **scene_fields)
    return Simulation(SimCfg(physics_dt_s=PHYSICS_DT_S, gravity_mps2=gravity_mps2, use_graph=False), scene,
                      NUM_ENVS, "cpu", 4 * PHYSICS_DT_S)


def reset_all(sim: Simulation) -> torch.Tensor:
    everyone = torch.ones(NUM_ENVS, dtype=torch.bool)
    sim.reset_worlds(everyone)
    sim.scene.reset_to_default(everyone)
    sim.forward(everyone)
    sim.scene.update()
    return everyone


def test_dropped_box_lands_after_the_free_fall_time_and_rests_at_its_half_height():
    drop_m = 0.5
    sim = make_sim({"box": RigidObjectCfg(shape=BoxShapeCfg(size_m=(BOX_EDGE_M,) * 3), mass_kg=1.0,
                                          init_pos_m=(0.0, 0.0, BOX_EDGE_M / 2 + drop_m))})
    reset_all(sim)
    box = sim.scene["box"]
    fall_s = math.sqrt(2.0 * drop_m / GRAVITY_MPS2)
    landed_at_s = None
    for step in range(1, 400):
        sim.step(1)
        # the fall ends at the first step whose downward speed is less than free fall predicts
        free_fall_speed = GRAVITY_MPS2 * step * PHYSICS_DT_S
        if landed_at_s is None and box.root_lin_vel_w[0, 2].item() > -free_fall_speed + 0.5:
            landed_at_s = step * PHYSICS_DT_S
    assert landed_at_s == pytest.approx(fall_s, abs=2 * PHYSICS_DT_S)
    sim.scene.update()
    assert torch.allclose(box.root_pos_w[:, 2], torch.full((NUM_ENVS,), BOX_EDGE_M / 2), atol=2e-3)
    assert torch.allclose(box.root_pos_w[:, :2], sim.env_origins[:, :2], atol=1e-3)  # at each env's own origin
    assert box.root_lin_vel_w.abs().max() < 1e-2


def test_box_pushed_with_a_known_impulse_moves_at_impulse_over_mass():
    mass_kg, force_n, push_steps = 2.0, 10.0, 4
    sim = make_sim({"box": RigidObjectCfg(shape=BoxShapeCfg(size_m=(BOX_EDGE_M,) * 3), mass_kg=mass_kg,
                                          init_pos_m=(0.0, 0.0, 1.0))}, gravity_mps2=0.0)
    reset_all(sim)
    box = sim.scene["box"]
    assert box.body_mass[:, 0].tolist() == pytest.approx([mass_kg] * NUM_ENVS)
    box.body_wrench_w[0, 0, 0] = force_n  # world 0 only
    sim.step(push_steps)
    box.body_wrench_w.zero_()
    sim.step(4)
    expected = force_n * push_steps * PHYSICS_DT_S / mass_kg
    assert box.root_lin_vel_w[0, 0].item() == pytest.approx(expected, rel=1e-3)
    assert box.root_lin_vel_w[1].abs().max().item() < 1e-6  # no crosstalk into world 1


def test_kinematic_and_fixed_objects_stay_where_they_are_put():
    sim = make_sim({"table": RigidObjectCfg(shape=BoxShapeCfg(size_m=(0.6, 0.6, 0.4)), body_type="fixed",
                                            init_pos_m=(1.0, 0.0, 0.2)),
                    "marker": RigidObjectCfg(shape=SphereShapeCfg(radius_m=0.05), body_type="kinematic",
                                             init_pos_m=(0.0, 0.0, 1.0))})
    reset_all(sim)
    table, marker = sim.scene["table"], sim.scene["marker"]
    assert table.is_fixed_base and not marker.is_fixed_base
    moved = marker.root_pose_w.clone()
    moved[:, 2] = 0.8
    marker.write_root_state(moved, torch.zeros(NUM_ENVS, 6), torch.tensor([True, False]))
    sim.forward()
    sim.step(40)
    sim.scene.update()
    assert marker.root_pos_w[:, 2].tolist() == pytest.approx([0.8, 1.0], abs=1e-4)  # gravity does not move it
    expected_table = sim.env_origins + torch.tensor([1.0, 0.0, 0.2])
    assert torch.allclose(table.body_pose_w[:, 0, :3], expected_table, atol=1e-5)


def test_fixed_object_follows_its_env_origin_at_reset():
    sim = make_sim({"table": RigidObjectCfg(shape=BoxShapeCfg(size_m=(0.6, 0.6, 0.4)), body_type="fixed",
                                            init_pos_m=(0.0, 0.0, 0.2)),
                    "box": RigidObjectCfg(shape=BoxShapeCfg(size_m=(BOX_EDGE_M,) * 3), init_pos_m=(0.0, 0.0, 0.6))})
    reset_all(sim)
    sim.env_origins[1, 0] += 3.0  # what a terrain-level change does
    reset_all(sim)
    sim.step(200)
    sim.scene.update()
    table, box = sim.scene["table"], sim.scene["box"]
    assert torch.allclose(table.body_pose_w[:, 0, :3], sim.env_origins + torch.tensor([0.0, 0.0, 0.2]), atol=1e-5)
    # the box fell onto the moved table in both worlds (its top is at 0.4 m), not through to the ground
    assert box.root_pos_w[:, 2].tolist() == pytest.approx([0.4 + BOX_EDGE_M / 2] * NUM_ENVS, abs=3e-3)


def test_masked_reset_touches_only_the_masked_worlds_of_the_named_entity():
    sim = make_sim({"a": RigidObjectCfg(shape=BoxShapeCfg(), init_pos_m=(0.0, 0.0, 0.05)),
                    "b": RigidObjectCfg(shape=BoxShapeCfg(), init_pos_m=(0.5, 0.0, 0.05))})
    reset_all(sim)
    a, b = sim.scene["a"], sim.scene["b"]
    before_a, before_b = a.root_pose_w.clone(), b.root_pose_w.clone()
    env = type("Env", (), {"scene": sim.scene, "num_envs": NUM_ENVS, "device": sim.device,
                           "env_origins": sim.env_origins})()
    asset = SceneEntityCfg("a")
    asset.resolve(env)
    mdp.reset_root_state_uniform(env, torch.tensor([False, True]), pose_range={"x": (0.2, 0.3), "z": (0.5, 0.5)},
                                 velocity_range={}, asset_cfg=asset)
    assert torch.equal(a.root_pose_w[0], before_a[0])
    assert a.root_pos_w[1, 2].item() == pytest.approx(before_a[1, 2].item() + 0.5)
    assert 0.2 <= (a.root_pos_w[1, 0] - before_a[1, 0]).item() <= 0.3
    assert torch.equal(b.root_pose_w, before_b)


def test_reset_root_is_the_default_pose_moved_and_turned_by_the_offsets():
    """`Entity.reset_root` (one kernel) gives what the torch composition gives: the default position at the env
    origin plus the offset, the default orientation turned by roll, pitch and yaw, the velocity as given; a fixed
    body takes the pose and keeps its velocity; unmasked worlds keep theirs."""
    from agile.utils.math import quat_from_euler_xyz, quat_mul

    sim = make_sim({"box": RigidObjectCfg(shape=BoxShapeCfg(), init_pos_m=(0.1, -0.2, 0.3),
                                          init_rot_xyzw=(0.0, 0.0, math.sin(0.3), math.cos(0.3))),
                    "table": RigidObjectCfg(shape=BoxShapeCfg(), body_type="fixed", init_pos_m=(1.0, 0.0, 0.2))})
    reset_all(sim)
    sim.env_origins[1, 0] += 3.0
    delta = torch.tensor([[0.1, 0.2, 0.3, 0.4, -0.5, 1.2], [-0.3, 0.0, 0.1, -0.2, 0.1, -2.9]])
    velocity = torch.tensor([[1.0, 2.0, 3.0, 0.1, 0.2, 0.3], [-1.0, 0.5, 0.0, 0.0, -0.2, 0.4]])
    for name in ("box", "table"):
        entity = sim.scene[name]
        before_pose, before_vel = entity.root_pose_w.clone(), entity.root_com_vel_w.clone()
        entity.reset_root(delta, velocity, torch.tensor([True, True]))
        position = entity.default_root_pose[:, :3] + (sim.env_origins + delta[:, :3])
        quat = quat_mul(quat_from_euler_xyz(delta[:, 3], delta[:, 4], delta[:, 5]), entity.default_root_pose[:, 3:7])
        torch.testing.assert_close(entity.root_pose_w, torch.cat((position, quat), dim=1), rtol=0.0, atol=1e-6)
        torch.testing.assert_close(entity.root_com_vel_w, before_vel if entity.is_fixed_base else velocity)
        entity.reset_root(delta * 2.0, velocity * 2.0, torch.tensor([False, False]))  # nothing masked: unchanged
        torch.testing.assert_close(entity.root_pose_w, torch.cat((position, quat), dim=1), rtol=0.0, atol=1e-6)
        assert not torch.equal(entity.root_pose_w, before_pose)


def stacked_boxes(filter_entity: str) -> Simulation:
    """'hand' rests on a fixed 'table' and carries an 'object' (1 kg on 0.5 kg)."""
    half = BOX_EDGE_M / 2
    return make_sim(
        {"table": RigidObjectCfg(shape=BoxShapeCfg(size_m=(0.4, 0.4, 0.2)), body_type="fixed", init_pos_m=(0, 0, 0.1)),
         "hand": RigidObjectCfg(shape=BoxShapeCfg(size_m=(BOX_EDGE_M,) * 3), mass_kg=0.5, init_pos_m=(0, 0, 0.2 + half)),
         "object": RigidObjectCfg(shape=BoxShapeCfg(size_m=(BOX_EDGE_M,) * 3), mass_kg=1.0,
                                  init_pos_m=(0, 0, 0.2 + 3 * half))},
        contact_sensors={"hand_contact": ContactSensorCfg(entity="hand", filter_entity=filter_entity,
                                                          track_air_time=False, history_length=1)})


def test_contact_filter_reports_hand_object_force_and_not_hand_table_force():
    sim = stacked_boxes("object")
    reset_all(sim)
    sim.step(100)
    sensor = sim.scene["hand_contact"]
    net_z = sensor.net_forces_w[:, 0, 2]
    from_object = sensor.force_matrix_w[:, 0].sum(dim=1)
    # at rest: the table holds both boxes up, the object presses down with its weight
    assert net_z.tolist() == pytest.approx([0.5 * GRAVITY_MPS2] * NUM_ENVS, rel=0.02)
    assert from_object[:, 2].tolist() == pytest.approx([-1.0 * GRAVITY_MPS2] * NUM_ENVS, rel=0.02)
    assert from_object[:, :2].abs().max() < 0.05


def test_contact_filter_on_the_ground():
    sim = make_sim({"box": RigidObjectCfg(shape=BoxShapeCfg(size_m=(BOX_EDGE_M,) * 3), mass_kg=1.0,
                                          init_pos_m=(0.0, 0.0, BOX_EDGE_M / 2))},
                   contact_sensors={"feet": ContactSensorCfg(entity="box", filter_entity=GROUND)})
    reset_all(sim)
    sim.step(40)
    sensor = sim.scene["feet"]
    assert sensor.force_matrix_w.shape == (NUM_ENVS, 1, 1, 3)
    assert torch.allclose(sensor.force_matrix_w[:, 0, 0], sensor.net_forces_w[:, 0], atol=1e-3)
    assert sensor.net_forces_w[:, 0, 2].tolist() == pytest.approx([GRAVITY_MPS2] * NUM_ENVS, rel=0.02)


def test_mesh_file_object_loads_through_trimesh(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    path = tmp_path / "cube.obj"
    trimesh.creation.box(extents=(BOX_EDGE_M,) * 3).export(path)
    sim = make_sim({"mesh": RigidObjectCfg(shape=MeshFileShapeCfg(path=str(path)), init_pos_m=(0.0, 0.0, 0.3))})
    reset_all(sim)
    sim.step(200)
    sim.scene.update()
    assert sim.scene["mesh"].body_mass[0, 0].item() == pytest.approx(1000.0 * BOX_EDGE_M ** 3, rel=0.02)
    assert sim.scene["mesh"].root_pos_w[:, 2].tolist() == pytest.approx([BOX_EDGE_M / 2] * NUM_ENVS, abs=3e-3)


# -- bad input: clear errors at build, naming the entity and the field -----------------------------------------

def test_an_entity_and_a_sensor_with_one_name_are_refused():
    with pytest.raises(ConfigError, match="'box' is already used in scene.entities"):
        make_sim({"box": RigidObjectCfg()}, contact_sensors={"box": ContactSensorCfg(entity="box")})


def test_a_sensor_naming_a_missing_entity_lists_the_entities():
    with pytest.raises(ConfigError, match=r"contact_sensors.touch.entity: no entity 'robot'.*\['box'\]"):
        make_sim({"box": RigidObjectCfg()}, contact_sensors={"touch": ContactSensorCfg(entity="robot")})


def test_a_filter_naming_a_missing_body_is_refused():
    with pytest.raises(ConfigError, match=r"contact_sensors.touch.filter_body_names.*finger"):
        make_sim({"box": RigidObjectCfg(), "other": RigidObjectCfg(init_pos_m=(1.0, 0.0, 0.5))},
                 contact_sensors={"touch": ContactSensorCfg(entity="box", filter_entity="other",
                                                            filter_body_names="finger")})


def test_an_object_file_that_does_not_load_names_the_entity(tmp_path):
    bad = tmp_path / "broken.obj"
    bad.write_text("this is not a mesh\n")
    with pytest.raises(ConfigError, match=r"scene.entities.rock: shape.path"):
        make_sim({"rock": RigidObjectCfg(shape=MeshFileShapeCfg(path=str(bad)))})
    with pytest.raises(ConfigError, match=r"scene.entities.prop: .*not found"):
        make_sim({"prop": RigidObjectCfg(shape=ModelFileShapeCfg(path=str(tmp_path / "missing.xml")))})


def test_a_mass_for_a_kinematic_object_is_refused():
    with pytest.raises(ConfigError, match=r"scene.entities.marker: mass_kg: a kinematic object has no mass"):
        make_sim({"marker": RigidObjectCfg(body_type="kinematic", mass_kg=1.0)})


def test_an_unknown_body_type_lists_the_valid_ones():
    with pytest.raises(ConfigError, match=r"scene.entities.box: body_type 'floating'.*'dynamic', 'kinematic', 'fixed'"):
        make_sim({"box": RigidObjectCfg(body_type="floating")})


def test_randomisation_events_act_on_the_named_object_only():
    import warp as wp

    sim = make_sim({"a": RigidObjectCfg(shape=BoxShapeCfg(), mass_kg=1.0, friction=1.0),
                    "b": RigidObjectCfg(shape=BoxShapeCfg(), mass_kg=1.0, friction=1.0, init_pos_m=(0.5, 0.0, 0.5))})
    reset_all(sim)
    env = type("Env", (), {"scene": sim.scene, "num_envs": NUM_ENVS, "device": sim.device, "sim": sim})()
    asset = SceneEntityCfg("a")
    asset.resolve(env)
    everyone = torch.ones(NUM_ENVS, dtype=torch.bool)
    mdp.randomize_rigid_body_material(env, everyone, static_friction_range=(0.3, 0.4),
                                      dynamic_friction_range=(0.3, 0.4), restitution_range=(0.0, 0.0),
                                      asset_cfg=asset)
    mdp.randomize_rigid_body_mass(env, everyone, mass_distribution_params=(2.0, 2.0), operation="add",
                                  asset_cfg=asset)
    mu = wp.to_torch(sim.model.shape_material_mu)
    a, b = sim.scene["a"], sim.scene["b"]
    assert ((mu[a.shape_ids] >= 0.3 - 1e-6) & (mu[a.shape_ids] <= 0.4 + 1e-6)).all()
    assert torch.allclose(mu[b.shape_ids], torch.ones_like(mu[b.shape_ids]))
    assert a.body_mass[:, 0].tolist() == pytest.approx([3.0] * NUM_ENVS)
    assert b.body_mass[:, 0].tolist() == pytest.approx([1.0] * NUM_ENVS)


def test_env_frame_pose_and_external_wrench():
    sim = make_sim({"box": RigidObjectCfg(shape=BoxShapeCfg(), mass_kg=1.0, init_pos_m=(0.2, -0.1, 1.0))},
                   gravity_mps2=0.0)
    reset_all(sim)
    box = sim.scene["box"]
    assert torch.allclose(box.root_pos_env, torch.tensor([[0.2, -0.1, 1.0]] * NUM_ENVS), atol=1e-6)
    wrench = torch.zeros(NUM_ENVS, 1, 6)
    wrench[..., 2] = 4.0  # 4 N up on a 1 kg box
    box.set_external_wrench(wrench, torch.tensor([False, True]))
    sim.step(20)  # 0.1 s
    assert box.root_lin_vel_w[:, 2].tolist() == pytest.approx([0.0, 0.4], abs=1e-4)
    box.write_root_state_env(box.default_root_pose, torch.zeros(NUM_ENVS, 6), torch.ones(NUM_ENVS, dtype=torch.bool))
    sim.scene.update()
    assert torch.allclose(box.root_pos_env, torch.tensor([[0.2, -0.1, 1.0]] * NUM_ENVS), atol=1e-6)


def test_model_file_object_keeps_the_files_shape_and_mass(tmp_path):
    path = tmp_path / "crate.xml"
    path.write_text("""<mujoco><worldbody><body name="crate"><freejoint/>
        <geom type="box" size="0.05 0.05 0.05" mass="0.7"/></body></worldbody></mujoco>""")
    sim = make_sim({"crate": RigidObjectCfg(shape=ModelFileShapeCfg(path=str(path)), init_pos_m=(0.0, 0.0, 0.4))})
    reset_all(sim)
    crate = sim.scene["crate"]
    assert crate.body_names == ["crate"] and crate.body_mass[:, 0].tolist() == pytest.approx([0.7] * NUM_ENVS)
    sim.step(200)
    sim.scene.update()
    assert crate.root_pos_w[:, 2].tolist() == pytest.approx([0.05] * NUM_ENVS, abs=3e-3)


def test_collider_margin_is_set_on_every_collider_and_a_negative_one_refused():
    """Go1's file has 1 mm margins (which Newton zeroes, warning per geom, under MuJoCo's own contacts): the robot
    definition's margin replaces them on every collider; None keeps the file's."""
    import dataclasses

    import newton

    from agile.assets.unitree_go1 import go1_robot_cfg
    from agile.sim.entities.model_import import build_articulation

    def collider_margins(cfg) -> list[float]:
        builder, _, _ = build_articulation(cfg, -9.81)
        collide = int(newton.ShapeFlags.COLLIDE_SHAPES)
        return [builder.shape_margin[i] for i in range(builder.shape_count) if builder.shape_flags[i] & collide]

    cfg = go1_robot_cfg()
    assert set(collider_margins(dataclasses.replace(cfg, collider_margin_m=0.002))) == {0.002}
    kept = collider_margins(dataclasses.replace(cfg, collider_margin_m=None))
    assert len(kept) == 42 and all(abs(m - 0.001) < 1e-9 for m in kept)
    with pytest.raises(ValueError, match="collider_margin_m must be >= 0"):
        collider_margins(dataclasses.replace(cfg, collider_margin_m=-0.001))
