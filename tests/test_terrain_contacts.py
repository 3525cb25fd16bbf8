"""Probe contacts against the terrain height field (agile/sim/terrain_contacts.py), against hand-computed values."""

import math

import newton
import numpy as np
import pytest
import torch
import warp as wp

from agile.sim import SceneCfg, SimCfg, Simulation
from agile.sim.simulation import terrain_heightfield
from agile.sim.terrain import TerrainData, TerrainGeneratorCfg
from agile.sim.terrain_contacts import TerrainContacts
from agile.utils.config import ConfigError

SPACING_M = 0.1
SAMPLES = 41  # a 4 m x 4 m field centred on the origin
GAP_M = 0.02  # each shape's, so contacts within 0.04 m


def field(heights_m: np.ndarray) -> TerrainData:
    half = (SAMPLES - 1) * SPACING_M / 2
    return TerrainData(heights_m=heights_m.astype(np.float32), origin_xy_m=(-half, -half), horizontal_scale_m=SPACING_M,
                       cell_origins_m=np.zeros((1, 1, 3), np.float32), cell_types=np.zeros((1, 1), np.int32),
                       cell_difficulty=np.zeros((1, 1), np.float32), type_names=["test"])


def flat(z_m: float = 0.0) -> TerrainData:
    return field(np.full((SAMPLES, SAMPLES), z_m))


def slope_x(angle_rad: float) -> TerrainData:
    xs = (np.arange(SAMPLES) - (SAMPLES - 1) / 2) * SPACING_M
    return field(np.repeat((math.tan(angle_rad) * xs)[:, None], SAMPLES, axis=1))


def contacts_of(terrain: TerrainData, add_shape, pos, rot=wp.quat_identity(), capacity: int = 64):
    """Probe contacts of one body carrying the shape `add_shape(builder, body)` adds, at pose (pos, rot)."""
    builder = newton.ModelBuilder()
    body = builder.add_body(xform=wp.transform(wp.vec3(*pos), rot))
    shape = add_shape(builder, body)
    terrain_shape = builder.add_shape_heightfield(heightfield=terrain_heightfield(terrain))
    model = builder.finalize(device="cpu")
    model.shape_gap.fill_(GAP_M)
    buffer = newton.Contacts(capacity, 0, device="cpu")
    probes = TerrainContacts(model, terrain, terrain_shape, [shape], buffer)
    buffer.clear()
    state = model.state()
    probes.collide(state)
    n = min(int(buffer.rigid_contact_count.numpy()[0]), capacity)
    body_q = state.body_q.numpy()[body]
    rot_np = np.array(wp.quat_to_matrix(wp.quat(*body_q[3:7]))).reshape(3, 3)
    core_w = (buffer.rigid_contact_point0.numpy()[:n] @ rot_np.T) + body_q[:3]
    normal = buffer.rigid_contact_normal.numpy()[:n]
    terrain_w = buffer.rigid_contact_point1.numpy()[:n]
    radius = buffer.rigid_contact_margin0.numpy()[:n]
    # Newton's separation: along the normal from shape0's surface (core + radius) to the terrain point
    dist = np.einsum("ij,ij->i", terrain_w - core_w, normal) - radius
    assert (buffer.rigid_contact_shape0.numpy()[:n] == shape).all()
    assert (buffer.rigid_contact_shape1.numpy()[:n] == terrain_shape).all()
    return dict(n=n, dist=dist, normal=normal, terrain_w=terrain_w, core_w=core_w,
                dropped=int(probes.dropped_contacts.item()), count=int(buffer.rigid_contact_count.numpy()[0]))


def sphere(r):
    return lambda b, body: b.add_shape_sphere(body, radius=r)


def capsule(r, half_height):
    return lambda b, body: b.add_shape_capsule(body, radius=r, half_height=half_height)


def box(hx, hy, hz):
    return lambda b, body: b.add_shape_box(body, hx=hx, hy=hy, hz=hz)


def cylinder(r, half_height):
    return lambda b, body: b.add_shape_cylinder(body, radius=r, half_height=half_height)


LYING = wp.quat_from_axis_angle(wp.vec3(0.0, 1.0, 0.0), math.pi / 2)  # the shape's z axis along world x
DOWN = np.array([0.0, 0.0, -1.0])


def test_sphere_on_flat_ground_one_contact_at_its_separation():
    c = contacts_of(flat(0.3), sphere(0.05), (0.02, -0.13, 0.3 + 0.05 + 0.01))
    assert c["n"] == 1
    assert c["dist"][0] == pytest.approx(0.01, abs=1e-5)
    assert np.allclose(c["normal"][0], DOWN) and np.allclose(c["terrain_w"][0], [0.02, -0.13, 0.3], atol=1e-5)


def test_out_of_reach_makes_no_contact():
    assert contacts_of(flat(), sphere(0.05), (0.0, 0.0, 0.05 + 2 * GAP_M + 0.005))["n"] == 0


def test_sphere_on_a_slope_separation_along_the_surface_normal():
    angle = 0.3
    c = contacts_of(slope_x(angle), sphere(0.05), (0.43, 0.0, math.tan(angle) * 0.43 + 0.07))
    assert c["n"] == 1
    assert c["dist"][0] == pytest.approx(0.07 * math.cos(angle) - 0.05, abs=1e-5)
    assert np.allclose(c["normal"][0], [math.sin(angle), 0.0, -math.cos(angle)], atol=1e-5)


def test_lying_capsule_touches_with_both_ends():
    c = contacts_of(flat(), capsule(0.03, 0.2), (0.0, 0.0, 0.03 - 0.002), LYING)
    assert c["n"] == 2
    assert np.allclose(c["dist"], -0.002, atol=1e-5)
    assert sorted(np.round(c["terrain_w"][:, 0], 4)) == [-0.2, 0.2]


def test_box_corners_and_samples_under_the_sole():
    # 0.3 x 0.15 m sole 5 mm above the ground: 4 corners, and the samples strictly under it (x in -0.1..0.1 at 0.1 m,
    # y = 0 only: the sole spans y in +-0.075), every one 5 mm away along -z
    c = contacts_of(flat(), box(0.15, 0.075, 0.05), (0.0, 0.0, 0.055))
    assert c["n"] == 4 + 3
    assert np.allclose(c["dist"], 0.005, atol=1e-5) and np.allclose(c["normal"], DOWN, atol=1e-6)


def test_a_ridge_under_a_sole_pushes_on_the_bottom_face():
    heights = np.zeros((SAMPLES, SAMPLES))
    heights[SAMPLES // 2, SAMPLES // 2] = 0.03  # one sample 3 cm up at the origin
    c = contacts_of(field(heights), box(0.15, 0.075, 0.05), (0.0, 0.0, 0.05 + 0.01))
    deepest = int(np.argmin(c["dist"]))
    assert c["dist"][deepest] == pytest.approx(-0.02, abs=1e-5)
    assert np.allclose(c["terrain_w"][deepest], [0.0, 0.0, 0.03], atol=1e-5)
    assert np.allclose(c["normal"][deepest], DOWN, atol=1e-6)


def test_spike_beside_a_box_pushes_on_the_side_face():
    heights = np.zeros((SAMPLES, SAMPLES))
    heights[SAMPLES // 2 + 1, SAMPLES // 2] = 0.5  # a 0.5 m spike at x = 0.1 m
    c = contacts_of(field(heights), box(0.105, 0.1, 0.1), (0.0, 0.0, 0.25))  # the box spans x <= 0.105, z 0.15-0.35
    side = [i for i in range(c["n"]) if np.allclose(c["terrain_w"][i], [0.1, 0.0, 0.5], atol=1e-5)]
    assert len(side) == 0  # the spike's tip is above the box: the sample is not inside it
    c = contacts_of(field(heights), box(0.105, 0.1, 0.1), (0.0, 0.0, 0.45))  # now the tip is 0.15 m inside
    side = [i for i in range(c["n"]) if np.allclose(c["terrain_w"][i], [0.1, 0.0, 0.5], atol=1e-5)]
    assert len(side) == 1
    assert np.allclose(c["normal"][side[0]], [1.0, 0.0, 0.0], atol=1e-6)
    assert c["dist"][side[0]] == pytest.approx(-0.005, abs=1e-5)


def test_upright_cylinder_stands_on_a_tripod_of_its_bottom_rim():
    c = contacts_of(flat(), cylinder(0.04, 0.1), (0.0, 0.0, 0.1 + 0.003))
    assert c["n"] == 3
    assert np.allclose(c["dist"], 0.003, atol=1e-5)
    assert np.allclose(np.linalg.norm(c["terrain_w"][:, :2], axis=1), 0.04, atol=1e-5)


def test_lying_cylinder_touches_along_its_lowest_line():
    c = contacts_of(flat(), cylinder(0.04, 0.1), (0.0, 0.0, 0.04 + 0.003), LYING)
    lowest = np.isclose(c["dist"], 0.003, atol=1e-5)
    assert lowest.sum() == 2 and np.allclose(np.abs(c["terrain_w"][lowest, 0]), 0.1, atol=1e-5)


def test_full_buffer_counts_dropped_contacts():
    c = contacts_of(flat(), box(0.15, 0.075, 0.05), (0.0, 0.0, 0.055), capacity=3)
    assert c["n"] == 3 and c["dropped"] == 7 - 3


def test_unsupported_collider_is_named():
    builder = newton.ModelBuilder()
    body = builder.add_body()
    builder.add_shape_ellipsoid(body, rx=0.1, ry=0.05, rz=0.05, label="egg")
    terrain = flat()
    terrain_shape = builder.add_shape_heightfield(heightfield=terrain_heightfield(terrain))
    model = builder.finalize(device="cpu")
    with pytest.raises(ValueError, match=r"egg \(ELLIPSOID\).*newton_pipeline"):
        TerrainContacts(model, terrain, terrain_shape, [0], newton.Contacts(8, 0, device="cpu"))


def test_unknown_terrain_collision_lists_the_valid_names():
    scene = SceneCfg(terrain=TerrainGeneratorCfg(size_m=2.0, num_rows=1, num_cols=1), terrain_collision="mujoco")
    with pytest.raises(ConfigError, match=r"scene.terrain_collision must be one of \['probes', 'newton_pipeline'\]"):
        Simulation(SimCfg(), scene, 1, "cpu", 0.02)


@pytest.mark.slow
def test_two_entities_on_a_terrain_rest_on_each_other_and_on_the_terrain():
    # the box-box pair goes through Newton's pipeline (explicit pairs), each box and the terrain through the probes
    from agile.sim import BoxShapeCfg, RigidObjectCfg

    flat_cells = TerrainGeneratorCfg(size_m=2.0, num_rows=1, num_cols=1, border_width_m=0.5)
    scene = SceneCfg(terrain=flat_cells, entities={
        "lower": RigidObjectCfg(shape=BoxShapeCfg(size_m=(0.2, 0.2, 0.2)), mass_kg=1.0, init_pos_m=(0.0, 0.0, 0.11)),
        "upper": RigidObjectCfg(shape=BoxShapeCfg(size_m=(0.1, 0.1, 0.1)), mass_kg=0.5, init_pos_m=(0.0, 0.0, 0.27))})
    sim = Simulation(SimCfg(use_graph=False), scene, 2, "cpu", 0.02)
    assert sim.collision_pipeline is not None and sim.terrain_contacts is not None
    sim.step(200)  # 1 s
    ground_z = sim.env_origins[:, 2]
    assert torch.allclose(sim.scene["lower"].root_pos_w[:, 2] - ground_z, torch.full((2,), 0.1), atol=3e-3)
    assert torch.allclose(sim.scene["upper"].root_pos_w[:, 2] - ground_z, torch.full((2,), 0.25), atol=4e-3)
