"""StandUp-T1 and its fallen-state dataset (issue 17): the cache key, the cache file's checks, collection (states
at rest, inside their cells), the reset from the dataset, the relative joint action, the built env then one PPO
iteration, and play.py --validate_fallen_states."""

from __future__ import annotations

import dataclasses
import types
from pathlib import Path

import pytest
import torch
from commands import run_command

import agile.tasks
from agile.tasks.stand_up.fallen_states import STATE_FIELDS, FallenStateDatasetCfg, cache
from agile.tasks.stand_up.fallen_states.dataset import cache_inputs

TASK = "StandUp-T1-v0"
ROOT = Path(__file__).resolve().parents[1]


def _key(env_cfg, num_envs: int = 4, dataset: FallenStateDatasetCfg | None = None) -> str:
    env = types.SimpleNamespace(cfg=env_cfg, num_envs=num_envs)
    return cache.cache_key(cache_inputs(env, dataset or FallenStateDatasetCfg(), "robot"))


def test_cache_key_changes_with_each_input_and_nothing_else(tmp_path):
    env_cfg, _ = agile.tasks.load_cfgs(TASK)
    base = _key(env_cfg)
    assert _key(agile.tasks.load_cfgs(TASK)[0]) == base  # rebuilt config, same key
    assert _key(env_cfg, dataset=FallenStateDatasetCfg(cache_dir=str(tmp_path), use_cache=False)) == base
    changed = {
        "dataset": _key(env_cfg, dataset=FallenStateDatasetCfg(settle_time_s=3.0)),
        "num_envs": _key(env_cfg, num_envs=8),
    }
    cfg = agile.tasks.load_cfgs(TASK)[0]
    cfg.scene.terrain = dataclasses.replace(cfg.scene.terrain, num_rows=4)
    changed["terrain"] = _key(cfg)
    cfg = agile.tasks.load_cfgs(TASK)[0]
    cfg.sim.physics_dt_s = 0.004
    changed["physics_dt_s"] = _key(cfg)
    cfg = agile.tasks.load_cfgs(TASK)[0]
    cfg.actions.joint_pos.scale = 0.2
    changed["actions"] = _key(cfg)
    cfg = agile.tasks.load_cfgs(TASK)[0]
    cfg.scene.entities["robot"].init_pos_m = (0.0, 0.0, 0.9)
    changed["robot cfg"] = _key(cfg)
    model_copy = tmp_path / "t1.xml"
    model_copy.write_text(Path(cfg.scene.entities["robot"].model_file).read_text() + "\n<!-- edited -->\n")
    cfg = agile.tasks.load_cfgs(TASK)[0]
    cfg.scene.entities["robot"].model_file = str(model_copy)
    changed["robot model file"] = _key(cfg)
    assert all(key != base for key in changed.values()), changed
    assert len(set(changed.values())) == len(changed)


def test_a_cache_file_is_used_only_when_whole_and_made_for_the_key(tmp_path):
    states = {name: torch.arange(6, dtype=torch.float32).reshape(3, 2) for name in STATE_FIELDS}
    path = tmp_path / "states.pt"
    cache.save_states(path, "abc", states)
    loaded, why = cache.load_states(path, "abc", STATE_FIELDS)
    assert why == "" and torch.equal(loaded["level"], states["level"])
    assert not list(tmp_path.glob("*.tmp*"))  # written through a temporary file, renamed
    assert cache.load_states(path, "other", STATE_FIELDS)[1].startswith("made for another")
    assert cache.load_states(tmp_path / "missing.pt", "abc", STATE_FIELDS)[1] == "no cache file yet"
    data = path.read_bytes()
    (tmp_path / "truncated.pt").write_bytes(data[: len(data) // 2])
    assert cache.load_states(tmp_path / "truncated.pt", "abc", STATE_FIELDS)[1].startswith("unreadable")
    (tmp_path / "noise.pt").write_bytes(b"\x00garbage" * 100)
    assert cache.load_states(tmp_path / "noise.pt", "abc", STATE_FIELDS)[1].startswith("unreadable")
    torch.save({"actor_state_dict": {}}, tmp_path / "foreign.pt")  # e.g. a checkpoint under the cache's name
    assert cache.load_states(tmp_path / "foreign.pt", "abc", STATE_FIELDS)[1] == "not a fallen-state cache"
    cache.save_states(tmp_path / "partial.pt", "abc", {"level": states["level"]})
    assert cache.load_states(tmp_path / "partial.pt", "abc", STATE_FIELDS)[1].startswith("incomplete")


def _small_env_cfg(cache_dir: Path, num_rows: int = 2):
    env_cfg, agent_cfg = agile.tasks.load_cfgs(TASK)
    env_cfg.num_envs = 3
    env_cfg.check_capture_safety = True  # every test's steps after the warm-up: nothing the GPU's graph refuses
    env_cfg.scene.terrain = dataclasses.replace(env_cfg.scene.terrain, num_rows=num_rows, num_cols=3)
    env_cfg.events.reset_base.params["dataset"] = FallenStateDatasetCfg(cache_dir=str(cache_dir))
    return env_cfg, agent_cfg


@pytest.fixture(scope="module")
def stand_up_env(tmp_path_factory):
    """StandUp-T1 with 3 envs on 2 terrain rows, its dataset made when built: (env, agent cfg, cache dir, printed)."""
    import contextlib
    import io

    from agile.run import task_setup

    cache_dir = tmp_path_factory.mktemp("fallen_cache")
    env_cfg, agent_cfg = _small_env_cfg(cache_dir)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        env = task_setup.make_env(task=TASK, env_cfg=env_cfg, device="cpu")
    return env, agent_cfg, cache_dir, out.getvalue()


def test_collected_states_lie_at_rest_inside_their_cells(stand_up_env):
    env, _, cache_dir, printed = stand_up_env
    assert "collected in" in printed and f"cached in {cache_dir}" in printed
    states = env.event_manager.get_term("reset_base").states
    t = states.tensors
    dropped = int(printed.split(" dropped")[0].rsplit(": ", 1)[1].split(" of ")[0]) if " dropped" in printed else 0
    # 3 envs x 1 drop x 2 rows, minus those not at rest (about 4% of drops: 14 of 384 on CPU, 1456 of 32768 on an H200)
    assert len(states) == 3 * 1 * 2 - dropped and dropped <= 2
    half_cell = env.sim.terrain_cell_size_m / 2 - FallenStateDatasetCfg().cell_margin_m
    assert (t["root_pos_env_m"][:, :2].abs() <= half_cell + 1e-6).all()
    assert (t["root_pos_env_m"][:, 2] < 0.4).all()  # lying: the trunk far below its standing 0.65 m
    assert (torch.linalg.norm(t["root_vel_w"][:, :3], dim=1) <= 0.5).all()  # settled after 2.5 s
    assert torch.isclose(torch.linalg.norm(t["root_quat_xyzw"], dim=1), torch.ones(len(states))).all()
    assert set(t["terrain_type"].tolist()) <= {0, 1, 2} and t["level"].tolist() == sorted(t["level"].tolist())


def test_reset_draws_fallen_states_at_the_env_row_and_a_standing_share(stand_up_env):
    env, _, _, _ = stand_up_env
    term = env.event_manager.get_term("reset_base")
    robot = env.scene["robot"]
    all_envs = torch.ones(env.num_envs, dtype=torch.bool)
    env.sim.set_terrain_levels(torch.tensor([1, 1, 0]))
    term(env, all_envs, standing_ratio=0.0)
    t = term.states.tensors
    assert env.sim.terrain_levels.tolist() == [1, 1, 0]
    root_env = robot.root_pos_w - env.env_origins
    match = [(t["level"] == env.sim.terrain_levels[i]) & (t["terrain_type"] == env.sim.terrain_types[i])
             & torch.isclose(t["root_pos_env_m"], root_env[i], atol=1e-5).all(dim=1) for i in range(3)]
    assert all(m.any() for m in match), "each env holds a state of its own row, in that state's cell"
    env.scene.reset_to_default(all_envs)
    term(env, all_envs, standing_ratio=1.0)
    assert torch.allclose(robot.root_pos_w[:, 2], robot.default_root_pose[:, 2] + env.env_origins[:, 2])
    assert torch.allclose(robot.joint_pos, robot.default_joint_pos)
    env.reset()


def test_relative_joint_action_steps_from_the_current_position(stand_up_env):
    env, _, _, _ = stand_up_env
    term = env.action_manager.get_term("joint_pos")
    robot = env.scene["robot"]
    action = torch.full((env.num_envs, term.action_dim), 0.5)
    action[:, 0] = 20.0  # a 2 rad step, clipped to 1 rad (the clip bounds action x scale, as Isaac Lab's)
    term.process_actions(action)
    term.apply_actions()
    expected = robot.joint_pos[:, term.joint_ids] + 0.05
    expected[:, 0] = robot.joint_pos[:, term.joint_ids[0]] + 1.0
    assert torch.allclose(robot.joint_pos_target[:, term.joint_ids], expected, atol=1e-6)


def _build(env_cfg) -> tuple[object, str]:
    import contextlib
    import io

    from agile.run import task_setup

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        env = task_setup.make_env(task=TASK, env_cfg=env_cfg, device="cpu")
    return env, out.getvalue()


def test_a_second_build_loads_the_cache_and_a_cut_cache_is_rebuilt(stand_up_env):
    _, _, cache_dir, _ = stand_up_env
    env, printed = _build(_small_env_cfg(cache_dir)[0])  # the same inputs: loaded, not collected
    assert "loaded from the cache" in printed and "collected" not in printed
    assert len(env.event_manager.get_term("reset_base").states) > 0
    [cache_file] = cache_dir.iterdir()
    cache_file.write_bytes(cache_file.read_bytes()[:100])  # a write cut short
    _, printed = _build(_small_env_cfg(cache_dir)[0])
    assert "is unreadable" in printed and "collected in" in printed
    assert cache.load_states(cache_file, cache_file.stem.rsplit("_", 1)[1], STATE_FIELDS)[1] == ""  # rebuilt
    _, printed = _build(_small_env_cfg(cache_dir, num_rows=3)[0])  # another terrain: another file
    assert "collected in" in printed and len(list(cache_dir.iterdir())) == 2


def test_a_seeded_build_draws_the_same_numbers_whether_it_collects_or_loads(tmp_path):
    """The collection runs on forked generators: after the build (which resets every env) the next random numbers,
    and so every later reset, are the same for the build that collected the dataset and the one that loaded it."""
    after = []
    for expected in ("collected in", "loaded from the cache"):
        env, printed = _build(_small_env_cfg(tmp_path)[0])
        assert expected in printed
        after.append((env.scene["robot"].root_pose_w.clone(), torch.rand(8)))
    (pose_collected, draws_collected), (pose_loaded, draws_loaded) = after
    assert torch.equal(pose_collected, pose_loaded) and torch.equal(draws_collected, draws_loaded)


def test_the_built_env_then_one_ppo_iteration(stand_up_env, tmp_path):
    from rsl_rl.runners import OnPolicyRunner

    from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict

    env, agent_cfg, _, _ = stand_up_env
    agent_cfg.num_steps_per_env = 4
    agent_cfg.algorithm.num_mini_batches = 2
    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=str(tmp_path), device="cpu")
    runner.learn(num_learning_iterations=1)
    assert (tmp_path / "model_0.pt").is_file()
    assert not {name: int(n) for name, n in env.reward_manager.nonfinite_count.items() if int(n)}
    assert runner.alg.symmetry is not None  # the mirror covers every term, the contact forces too


def test_play_validate_fallen_states(tmp_path):  # also: the collection's progress bar, with its ETA
    code, out, err = run_command("play", "--task", TASK, "--device", "cpu", "--num_envs", "2", "--num_steps", "110",
                                 "--validate_fallen_states", "env.scene.terrain.num_rows=2",
                                 f"env.events.reset_base.params.dataset.cache_dir={tmp_path}", cwd=ROOT)
    assert code == 0, out[-2000:] + err[-2000:]
    assert "zero actions" in out and "fallen states:" in out
    assert "fallen states: 100%" in err and "2/2" in err  # a drop per row, then done
    assert "episodes ended 4, by failure 0" in out  # 2 envs reset every second for 2.2 s


def test_a_row_without_states_draws_from_the_nearest_row_with_some():
    from agile.tasks.stand_up.fallen_states import FallenStates

    levels = torch.tensor([1, 1, 3])  # rows 0 and 2 lost every state (not at rest)
    tensors = {name: torch.zeros(3, 1) for name in STATE_FIELDS}
    tensors["level"] = levels
    tensors["root_pos_env_m"] = torch.tensor([[10.0], [11.0], [30.0]])
    states = FallenStates(tensors, num_levels=4)
    assert states.source_level.tolist() == [1, 1, 1, 3]
    for _ in range(20):
        drawn = states.tensors["level"][states.sample(torch.tensor([0, 1, 2, 3, 7]))]
        assert drawn.tolist() == [1, 1, 1, 3, 3]


def _hold_default(env, steps: int) -> list[torch.Tensor]:
    """`steps` env steps holding every joint at its default position (the relative action's step to it); each
    step's root yaw rate [rad/s]."""
    robot, term = env.scene["robot"], env.action_manager.get_term("joint_pos")
    default = robot.default_joint_pos[:, term.joint_ids]
    yaw_rates = []
    for _ in range(steps):
        env.step(((default - robot.joint_pos[:, term.joint_ids]) / 0.1).clamp(-10.0, 10.0))
        yaw_rates.append(robot.root_ang_vel_w[:, 2].abs())
    return yaw_rates


def test_the_lifts_yaw_damping_does_not_spin_an_upright_t1(stand_up_env):
    # AGILE's 100 N·m·s/rad, applied explicitly at 5 ms, overshot on an upright T1 and spun it at 3 rad/s
    # (about 200 N·m flipping sign each physics step) for as long as the lift was at full strength
    env, _, _, _ = stand_up_env
    reset_params = env.event_manager.term_cfgs["reset_base"].params
    with torch.inference_mode():  # as the runner steps it (the PPO test may have run first)
        env.curriculum_manager.funcs["lift"].scale.fill_(1.0)
        reset_params["standing_ratio"] = 1.0
        try:
            env.reset()
            yaw_rates = torch.stack(_hold_default(env, 25))
            assert yaw_rates.mean().item() < 0.5, yaw_rates.mean(dim=0)
        finally:
            reset_params["standing_ratio"] = 0.1
            env.reset()


def test_illegal_contacts_cost_a_lying_t1_once_not_per_body(stand_up_env):
    # AGILE's illegal_contact is Isaac Lab's termination function: whether any listed body touches (1), not how many
    env, _, _, _ = stand_up_env
    reset_params = env.event_manager.term_cfgs["reset_base"].params
    with torch.inference_mode():
        reset_params["standing_ratio"] = 0.0
        try:
            env.reset()
            costs = []
            for _ in range(10):
                env.step(torch.zeros(env.num_envs, env.action_manager.total_action_dim))
                costs.append(env.reward_manager.step_reward["illegal_contacts"].clone())
            costs = torch.stack(costs)
            assert set(costs.unique().tolist()) <= {0.0, -1.0} and (costs == -1.0).any(), costs.unique()
        finally:
            reset_params["standing_ratio"] = 0.1
            env.reset()


def test_gym_make_starts_a_stand_up_task_from_fallen_states():
    """gym.make builds what training runs: the reset event collects (or loads) the fallen-state dataset when the
    env is built, and the envs start from it (a tenth standing, StandUp-T1's standing_ratio)."""
    import gymnasium as gym

    from agile.utils.math import quat_rotate_inverse

    env = gym.make("StandUp-T1-v0", num_envs=4, device="cpu").unwrapped
    robot = env.scene["robot"]
    down = torch.tensor([[0.0, 0.0, -1.0]]).expand(4, 3)
    upright = quat_rotate_inverse(robot.root_quat_w, down)[:, 2] < -0.9  # the trunk's z axis near vertical
    assert env.event_manager.get_term("reset_base").states is not None
    assert int((~upright).sum()) >= 3, robot.root_pos_w  # most start lying
    env.close()
