"""Terrain generator, cache, physics on the height field, height scanner and terrain curriculum (CPU)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from agile.rl_env.managers import CurrTerm
from agile.rl_env.mdp.curriculums import terrain_levels_vel
from agile.sim import ArticulationCfg, HeightScannerCfg, SceneCfg, SimCfg
from scenes import robot_sim
from agile.sim.terrain import (LESS_ROUGH_TERRAIN_CFG, MEDIUM_ROUGH_TERRAIN_CFG, STAND_UP_ROUGH_TERRAIN_CFG,
                               BoxGridTerrainCfg, FlatTerrainCfg, PyramidSlopeTerrainCfg, PyramidStairsTerrainCfg,
                               RandomUniformTerrainCfg, TerrainGeneratorCfg, WaveTerrainCfg, cache_dir, cache_key,
                               generate_terrain, load_or_generate_terrain)

SIZE_M = 4.0
H_M = 0.1


def cell(sub, difficulty: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x, y, z) sample grids of one cell, local coordinates."""
    local = (np.arange(round(SIZE_M / H_M)) - SIZE_M / H_M / 2) * H_M
    x, y = np.meshgrid(local, local, indexing="ij")
    return x, y, sub.heights(difficulty, x, y, SIZE_M, np.random.default_rng(seed))


def test_flat_is_zero():
    assert not cell(FlatTerrainCfg(), 1.0)[2].any()


@pytest.mark.parametrize("inverted", [False, True])
def test_pyramid_stairs_step_height(inverted):
    sub = PyramidStairsTerrainCfg(step_height_range_m=(0.05, 0.25), step_width_m=0.5, platform_width_m=1.0,
                                  border_width_m=0.5, inverted=inverted)
    x, y, z = cell(sub, 0.5)
    sign = -1.0 if inverted else 1.0
    step_m = 0.15  # 0.05 + 0.5 * (0.25 - 0.05)
    # border 0.5 m, then steps of 0.5 m: ring k (from outside) is k * step high, the 1 m platform 2 steps
    for x_m, steps in ((1.75, 0), (1.25, 1), (0.75, 2), (0.0, 2)):
        i = int(np.argmin(np.abs(x[:, 0] - x_m)))
        j = int(np.argmin(np.abs(y[0] - 0.0)))
        assert z[i, j] == pytest.approx(sign * steps * step_m), x_m
    assert sub.num_steps(SIZE_M) == 2


@pytest.mark.parametrize("inverted", [False, True])
def test_pyramid_slope_angle(inverted):
    sub = PyramidSlopeTerrainCfg(slope_range=(0.0, 0.4), platform_width_m=1.0, border_width_m=0.25, inverted=inverted)
    x, y, z = cell(sub, 1.0)
    on_face = (x[:, 0] > 0.6) & (x[:, 0] < 1.6)  # along +x between the platform and the border
    j = int(np.argmin(np.abs(y[0])))
    gradient = np.diff(z[on_face, j]) / H_M
    assert np.allclose(gradient, -0.4 if not inverted else 0.4, atol=1e-5)
    platform = (np.abs(x) < 0.5) & (np.abs(y) < 0.5)
    assert np.allclose(z[platform], (-1 if inverted else 1) * 0.4 * (2.0 - 0.25 - 0.5))
    assert cell(sub, 0.0)[2].max() == 0.0 and cell(sub, 0.0)[2].min() == 0.0


@pytest.mark.parametrize("difficulty", [0.0, 0.3, 1.0])
def test_random_uniform_amplitude_grows_with_difficulty(difficulty):
    sub = RandomUniformTerrainCfg(noise_range_m=(0.02, 0.10), noise_step_m=0.02, border_width_m=0.3)
    x, y, z = cell(sub, difficulty)
    inside = (np.abs(x) < SIZE_M / 2 - 0.3) & (np.abs(y) < SIZE_M / 2 - 0.3)
    assert not z[~inside].any()
    assert z[inside].min() >= 0.02 * difficulty - 1e-9 and z.max() <= 0.10 * difficulty + 1e-9
    if difficulty > 0:
        assert z[inside].max() == pytest.approx(0.10 * difficulty)  # the top level is drawn in 1400 samples
        levels = (z[inside] - 0.02 * difficulty) / (0.02 * difficulty)
        assert np.allclose(levels, np.round(levels), atol=1e-6)


def test_random_uniform_sample_spacing_draws_heights_on_a_coarser_grid():
    sub = RandomUniformTerrainCfg(noise_range_m=(0.0, 0.10), noise_step_m=0.01, border_width_m=0.0,
                                  sample_spacing_m=0.4)
    _, _, z = cell(sub, 1.0)  # samples every 0.1 m from -2.0 m (the cell's edge, held at 0)
    z = z[4:, 4:]  # from -1.6 m: every 4th sample is a drawn height
    drawn = z[::4, ::4]
    assert np.allclose(drawn / 0.01, np.round(drawn / 0.01), atol=1e-6) and np.unique(drawn).size > 5
    # in between, the surface is linear: a sample halfway between two drawn heights is their mean
    torch.testing.assert_close(torch.from_numpy(z[2::4, ::4][:-1]), torch.from_numpy((drawn[:-1] + drawn[1:]) / 2))
    torch.testing.assert_close(torch.from_numpy(z[::4, 1::4][:, :-1]),
                               torch.from_numpy(0.75 * drawn[:, :-1] + 0.25 * drawn[:, 1:]))
    # slopes between neighbouring samples are a quarter of drawing every sample's height
    assert np.abs(np.diff(z, axis=0)).max() <= 0.10 / 4 + 1e-9


def test_wave_amplitude_and_boxes_bound():
    _, _, z = cell(WaveTerrainCfg(amplitude_range_m=(0.0, 0.2), num_waves=2), 0.5)
    assert np.abs(z).max() <= 0.1 + 1e-9 and np.abs(z).max() > 0.09
    sub = BoxGridTerrainCfg(grid_width_m=0.5, grid_height_range_m=(0.0, 0.2), platform_width_m=1.0)
    x, y, z = cell(sub, 0.5)
    assert np.abs(z).max() <= 0.1 and np.abs(z).max() > 0.05
    assert not z[(np.abs(x) < 0.5) & (np.abs(y) < 0.5)].any()
    block = z[np.searchsorted(x[:, 0], 1.05):np.searchsorted(x[:, 0], 1.45), 1:5]  # x 1.1-1.4, y -1.9 to -1.6
    assert block.size == 16 and np.all(block == block[0, 0])  # one block is one height


def small_cfg(**kw) -> TerrainGeneratorCfg:
    args = dict(size_m=SIZE_M, num_rows=3, num_cols=4, border_width_m=1.0, horizontal_scale_m=H_M, seed=0,
                sub_terrains={"flat": FlatTerrainCfg(proportion=0.25),
                              "rough": RandomUniformTerrainCfg(proportion=0.5),
                              "stairs": PyramidStairsTerrainCfg(proportion=0.25, step_width_m=0.5,
                                                                platform_width_m=1.0, border_width_m=0.5)})
    args.update(kw)
    return TerrainGeneratorCfg(**args)


def test_layout_rows_are_difficulty_columns_are_types():
    data = generate_terrain(small_cfg())
    assert data.heights_m.shape == (3 * 40 + 2 * 10 + 1, 4 * 40 + 2 * 10 + 1)
    # row r: difficulties in [r, r + 1) / 3, different along the row
    rows = np.arange(3)[:, None]
    assert ((data.cell_difficulty >= rows / 3) & (data.cell_difficulty < (rows + 1) / 3)).all()
    assert np.unique(data.cell_difficulty[2]).size == 4
    assert data.cell_types[0].tolist() == [0, 1, 1, 2] and (data.cell_types == data.cell_types[0]).all()
    # the grid is centred, the cells' origins at their centres, on the highest point of the central 1 m
    assert np.allclose(data.cell_origins_m[:, :, 0].mean(), 0.0) and np.allclose(data.cell_origins_m[:, :, 1].mean(), 0)
    step_m = 0.05 + data.cell_difficulty[2, 3] * (0.23 - 0.05)  # the stairs' step height at that difficulty
    assert step_m > 0.16 and data.cell_origins_m[2, 3, 2] == pytest.approx(2 * step_m, abs=1e-6)  # two steps up
    assert data.cell_origins_m[0, 0, 2] == 0.0
    assert data.height_at(*data.cell_origins_m[2, 3, :2]) == pytest.approx(2 * step_m, abs=1e-6)
    assert data.height_at(100.0, 100.0) == 0.0  # flat border outside


def test_presets_generate():
    for preset, shape in ((LESS_ROUGH_TERRAIN_CFG, (20, 16)), (MEDIUM_ROUGH_TERRAIN_CFG, (20, 15)),
                          (STAND_UP_ROUGH_TERRAIN_CFG, (8, 9))):
        assert (preset.num_rows, preset.num_cols) == shape and preset.size_m == 8.0
    data = generate_terrain(STAND_UP_ROUGH_TERRAIN_CFG)
    assert data.cell_origins_m.shape == (8, 9, 3) and np.isfinite(data.heights_m).all()


def test_same_seed_same_terrain_other_seed_differs():
    a, b = generate_terrain(small_cfg(seed=3)), generate_terrain(small_cfg(seed=3))
    assert np.array_equal(a.heights_m, b.heights_m) and np.array_equal(a.cell_origins_m, b.cell_origins_m)
    c = generate_terrain(small_cfg(seed=4))
    assert not np.array_equal(a.heights_m, c.heights_m)
    assert cache_key(small_cfg(seed=3)) == cache_key(small_cfg(seed=3)) != cache_key(small_cfg(seed=4))
    assert cache_key(small_cfg()) != cache_key(small_cfg(border_width_m=2.0))


def test_cache_round_trip(tmp_path, monkeypatch):
    monkeypatch.setenv("AGILE_CACHE_DIR", str(tmp_path))
    cfg = small_cfg(seed=7)
    fresh = generate_terrain(cfg)
    first = load_or_generate_terrain(cfg)
    path = cache_dir() / f"terrain_{cache_key(cfg)}.npz"
    assert path.is_file() and path.parent == tmp_path / "terrain"
    # a hit gives the same arrays; prove it was read from disk by keeping the file's modification time
    mtime = path.stat().st_mtime_ns
    hit = load_or_generate_terrain(cfg)
    assert path.stat().st_mtime_ns == mtime
    for data in (first, hit):
        for name in ("heights_m", "cell_origins_m", "cell_types", "cell_difficulty"):
            assert np.array_equal(getattr(data, name), getattr(fresh, name)), name
        assert data.origin_xy_m == fresh.origin_xy_m and data.type_names == fresh.type_names
    # a damaged file is not trusted
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    arrays["heights_m"] = arrays["heights_m"] + 1.0
    np.savez(path, **arrays)
    assert np.array_equal(load_or_generate_terrain(cfg).heights_m, fresh.heights_m)


# -- the physics world on a terrain --------------------------------------------------------------------

BOX_XML = """<mujoco><worldbody><body name="base" pos="0 0 0.5"><freejoint/>
<geom name="box" type="box" size="0.1 0.1 0.1" mass="1"/>
<body name="tip" pos="0.15 0 0"><joint name="hinge" type="hinge" axis="0 1 0"/>
<geom type="sphere" size="0.02" mass="0.01" contype="0" conaffinity="0"/></body>
</body></worldbody></mujoco>"""
STAIRS = TerrainGeneratorCfg(size_m=SIZE_M, num_rows=3, num_cols=2, border_width_m=1.0, horizontal_scale_m=H_M,
                             sub_terrains={"stairs": PyramidStairsTerrainCfg(
                                 step_height_range_m=(0.1, 0.1), step_width_m=0.5, platform_width_m=1.0,
                                 border_width_m=0.5)})
NUM_ENVS = 4


@pytest.fixture(scope="module")
def box_sim(tmp_path_factory):
    path = tmp_path_factory.mktemp("robot") / "box.xml"
    path.write_text(BOX_XML)
    torch.manual_seed(0)
    return robot_sim(ArticulationCfg(model_file=str(path), init_pos_m=(0.0, 0.0, 0.3)), NUM_ENVS,
                     sim=SimCfg(use_graph=False), terrain=STAIRS, max_init_terrain_level=1,
                     height_scanners={"scan": HeightScannerCfg(body_name="base", size_m=(0.4, 0.2), resolution_m=0.1)})


def place(sim, offsets_xy_m: list[tuple[float, float]], height_m: float) -> None:
    """Put each env's box at its origin + offset, `height_m` above the origin, at rest."""
    pose = sim.scene["robot"].default_root_pose.clone()
    pose[:, :3] = sim.env_origins
    pose[:, :2] += torch.tensor(offsets_xy_m)
    pose[:, 2] += height_m
    everyone = torch.ones(sim.num_envs, dtype=torch.bool)
    sim.reset_worlds(everyone)
    sim.scene["robot"].write_root_state(pose, torch.zeros_like(sim.scene["robot"].root_com_vel_w), everyone)
    sim.forward()


def test_env_origins_come_from_terrain_cells(box_sim):
    sim = box_sim
    assert sim.terrain_types.tolist() == [0, 1, 0, 1]
    assert ((sim.terrain_levels >= 0) & (sim.terrain_levels <= 1)).all()
    assert torch.equal(sim.env_origins, sim.terrain_origins_m[sim.terrain_levels, sim.terrain_types])
    assert sim.terrain_origins_m[2, 0, 2].item() == pytest.approx(0.2)  # platform: two 0.1 m steps


def test_terrain_contacts_use_the_configured_gap(box_sim):
    # Newton's 0.1 m default gap made every foot collect contacts from every triangle within 10 cm
    gap = box_sim.model.shape_gap.numpy()
    assert np.all(gap == pytest.approx(SceneCfg().terrain_contact_gap_m)) and SceneCfg().terrain_contact_gap_m < 0.1


def test_box_rests_on_step_and_platform(box_sim):
    sim = box_sim
    # on the platform (0.2 m), on the first step ring (0.1 m), on the border (0 m), on the second ring (0.2 m)
    offsets = [(0.0, 0.0), (1.25, 0.0), (0.0, -1.8), (-0.75, 0.3)]
    place(sim, offsets, 0.15)
    sim.step(100)  # 0.5 s: falls ~3 cm and settles
    expected = sim.env_origins[:, 2] - 0.2 + torch.tensor([0.2, 0.1, 0.0, 0.2]) + 0.1  # box half height 0.1 m
    assert torch.allclose(sim.scene["robot"].root_pos_w[:, 2], expected, atol=3e-3), (sim.scene["robot"].root_pos_w, expected)
    assert torch.allclose(sim.scene["robot"].root_pos_w[:, :2], sim.env_origins[:, :2] + torch.tensor(offsets), atol=0.02)


def test_height_scan_hits_known_heights(box_sim):
    sim = box_sim
    place(sim, [(0.0, 0.0), (1.25, 0.0), (0.0, -1.8), (1.25, 0.0)], 0.5)
    scan = sim.scene.height_scanners["scan"]
    assert scan.num_rays == 5 * 3
    scan.update()
    ground = sim.env_origins[:, 2] - 0.2  # cell origins sit on the 0.2 m platform
    hit = scan.hit_z_m - ground.unsqueeze(1)
    assert torch.allclose(hit[0], torch.full((15,), 0.2))
    # rays at x = 1.05, 1.15 ... 1.45 from the centre: the 1.0 m sample is on the second step, the ramp
    # between samples is the collision surface as well
    assert torch.allclose(hit[1].view(3, 5), torch.tensor([0.15, 0.1, 0.1, 0.1, 0.05]).expand(3, 5), atol=1e-5)
    assert torch.allclose(hit[2], torch.zeros(15), atol=1e-6)
    assert torch.allclose(scan.base_height_m, sim.scene["robot"].root_pos_w[:, 2] - scan.hit_z_m.mean(dim=1))
    # the grid turns with the body's yaw: at 90 degrees its x extent lies along world y, on the 0.1 m ring
    pose = sim.scene["robot"].root_pose_w.clone()
    pose[3, 3:7] = torch.tensor([0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    sim.scene["robot"].write_root_state(pose, torch.zeros_like(sim.scene["robot"].root_com_vel_w), torch.tensor([0, 0, 0, 1]).bool())
    sim.forward()
    scan.update()
    rotated = scan.ray_xy_w[3] - sim.env_origins[3, :2]
    assert torch.allclose(rotated[:5, 1], torch.tensor([-0.2, -0.1, 0.0, 0.1, 0.2]), atol=1e-5)
    assert torch.allclose(scan.hit_z_m[3] - ground[3], torch.full((15,), 0.1), atol=1e-5)


def test_height_scan_on_flat_ground(tmp_path):
    path = tmp_path / "box.xml"
    path.write_text(BOX_XML)
    sim = robot_sim(ArticulationCfg(model_file=str(path), init_pos_m=(0.0, 0.0, 0.7)), 2, sim=SimCfg(use_graph=False),
                    height_scanners={"scan": HeightScannerCfg(body_name="base")})
    assert sim.terrain is None and sim.contacts is None  # the plane keeps MuJoCo's own contacts
    sim.forward()  # body poses from the default joint state
    scan = sim.scene.height_scanners["scan"]
    scan.update()
    assert scan.num_rays == 1 and not scan.hit_z_m.any()
    assert torch.allclose(scan.base_height_m, torch.full((2,), 0.7))


# -- curriculum ----------------------------------------------------------------------------------------


def test_terrain_levels_vel_moves_envs_up_and_down(box_sim):
    sim = box_sim
    command = torch.zeros(NUM_ENVS, 3)
    env = SimpleNamespace(sim=sim, num_envs=NUM_ENVS, device=sim.device, scene=sim.scene,
                          command_manager=SimpleNamespace(get_command=lambda name: command))
    params = dict(move_up_distance_m=4.0, move_down_distance_m=2.0, n_successes=4, n_failures=10)
    term = terrain_levels_vel(CurrTerm(func=terrain_levels_vel, params=params), env)
    sim.terrain_levels.fill_(1)
    nobody = torch.zeros(NUM_ENVS, dtype=torch.bool)
    sim.update_terrain_levels(nobody, nobody)
    everyone = ~nobody
    walked_m = torch.tensor([5.0, 1.0, 3.0, 1.0])

    def episode(turn_back_after_m: float | None = None) -> torch.Tensor:
        place(sim, [(0.0, 0.0)] * NUM_ENVS, 0.3)
        term(env, nobody, **params)  # episode start
        if turn_back_after_m is not None:  # walk out, a new command, walk back: the pieces add up
            sim.scene["robot"].root_pos_w[:, 0] += turn_back_after_m
            command[:, 0] += 1.0
            term(env, nobody, **params)
            sim.scene["robot"].root_pos_w[:, 0] -= turn_back_after_m - walked_m
        else:
            sim.scene["robot"].root_pos_w[:, 0] += walked_m
        return term(env, everyone, **params)  # episode end

    for _ in range(3):  # 10 m out and 10 - d back: every env walked more than 4 m
        episode(turn_back_after_m=10.0)
    assert sim.terrain_levels.tolist() == [1, 1, 1, 1]
    mean_level = episode(turn_back_after_m=10.0)  # the 4th success
    assert sim.terrain_levels.tolist() == [2, 2, 2, 2] and mean_level.item() == pytest.approx(2.0)
    for _ in range(10):
        episode()
    # env 0 walked 5 m: up 4 times more from row 2 (3 rows): wraps to a random row at the top
    # envs 1 and 3 walked 1 m: 10 failures, one row down; env 2 (3 m) neither succeeds nor fails
    assert sim.terrain_levels[[1, 2, 3]].tolist() == [1, 2, 1]
    assert 0 <= sim.terrain_levels[0].item() < 3
    assert torch.equal(sim.env_origins, sim.terrain_origins_m[sim.terrain_levels, sim.terrain_types])
    # random moves: p = 1 moves every ending env up (the row-0 floor and the top wrap keep levels valid)
    sim.terrain_levels.fill_(0)
    sim.update_terrain_levels(nobody, nobody)
    walked_m.fill_(3.0)
    params["p_random_move_up"] = 1.0
    episode()
    assert sim.terrain_levels.tolist() == [1, 1, 1, 1]
    params["p_random_move_up"], params["p_random_move_down"] = 0.0, 1.0
    episode()
    assert sim.terrain_levels.tolist() == [0, 0, 0, 0]


def test_height_scan_observation_and_terrain_relative_base_height(box_sim):
    from agile.rl_env.mdp.observations import height_scan
    from agile.rl_env.mdp.rewards import base_height_exp

    sim = box_sim
    place(sim, [(0.0, 0.0), (1.25, 0.0), (0.0, -1.8), (0.0, 0.0)], 0.6)
    sim.scene.height_scanners["scan"].update()  # what the env does once per step
    env = SimpleNamespace(scene=sim.scene)
    scan = height_scan(env, "scan", offset_m=0.5)
    # the body is 0.6 m above the cell origin, which sits on the platform under env 0
    assert torch.allclose(scan[0], torch.full((15,), 0.6 - 0.5), atol=1e-5)
    # env 2 is over the border, 0.2 m below the origin: 0.8 m, clipped
    assert torch.allclose(height_scan(env, "scan", offset_m=0.0, clip_m=(-0.5, 0.5))[2], torch.full((15,), 0.5))
    # 0.6 m above the platform: on target with the sensor; 0.8 m above z=0 without it (the flat behaviour)
    on_target = base_height_exp(env, target_height_m=0.6, std=0.1, sensor_name="scan")
    assert on_target[0].item() == pytest.approx(1.0, abs=1e-5)
    flat = base_height_exp(env, target_height_m=0.8, std=0.1)
    assert flat[0].item() == pytest.approx(1.0, abs=1e-5) and on_target[2].item() < 0.1
