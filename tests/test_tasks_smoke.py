"""Every registered task is built, stepped, reset and trained for one PPO iteration on CPU, or skipped with a reason."""

import gymnasium as gym
import pytest
import torch
from rsl_rl.runners import OnPolicyRunner

import agile.tasks
from agile.rl import RslRlVecEnvWrapper, to_rsl_rl_dict

SMOKE_TASKS = ["Velocity-T1-v0", "Velocity-G1-History-v0", "Velocity-G1-Teacher-v0", "Velocity-Height-G1-Teacher-v0",
               "Velocity-Height-G1-History-v0", "Debug-G1-v0", "Debug-T1-v0", "Debug-G1-Object-v0"]
SMOKE_TASKS += ["MotionTracking-G1-v0"]
SMOKE_TASKS += ["PickPlace-G1-v0", "PickPlace-G1-Debug-v0", "PickPlace-G1-Record-v0"]
SMOKE_TASKS += ["StandUp-T1-v0", "HeightTracking-G1-v0"]  # gym.make collects their fallen-state datasets
SMOKE_TASKS += ["Velocity-Go1-v0", "Velocity-Flat-Go1-v0"]
MULTI_AGENT_SMOKE_TASKS = ["MultiRate-G1-T1-Velocity-v0", "Shared-Go1-Velocity-v0"]
DISTILLED = "distilled from a teacher: tests/test_distillation.py builds, steps, trains and exports it"
FINETUNED = "PPO on a distilled student: tests/test_distillation.py trains it from the shipped student and exports it"
SKIPPED_TASKS: dict[str, str] = {  # task ID -> reason
    "Velocity-Height-G1-v0": "the same configs as Velocity-Height-G1-Teacher-v0 (two IDs, as AGILE registers them)",
    "Velocity-Height-G1-Student-Recurrent-v0": DISTILLED,
    "Velocity-Height-G1-Student-History-v0": DISTILLED,
    "Velocity-Height-G1-Student-Recurrent-Finetune-v0": FINETUNED,
    "Velocity-Height-G1-Student-History-Finetune-v0": FINETUNED,
    "Tracking-Flat-G1-v0": "the same configs as MotionTracking-G1-v0 (AGILE v1.3 renamed it; both IDs registered)",
    "G1-PickPlace-Tracking-v0": "the same configs as PickPlace-G1-v0 (AGILE v1.3 renamed it; both IDs registered)",
}


def test_every_registered_task_has_a_smoke_test_or_a_reason():
    missing = set(agile.tasks.registered_tasks()) - set(SMOKE_TASKS) - set(MULTI_AGENT_SMOKE_TASKS) - set(SKIPPED_TASKS)
    assert not missing, f"registered tasks without a smoke test: {sorted(missing)}"


def assert_in_space(space, value, where: str) -> None:
    """The observation matches its space: the same groups and terms, the same shapes."""
    if isinstance(space, gym.spaces.Dict):
        assert set(space.spaces) == set(value.keys()), f"{where}: space {sorted(space.spaces)}, obs {sorted(value.keys())}"
        for key, sub in space.spaces.items():
            assert_in_space(sub, value[key], f"{where}.{key}")
    else:
        assert tuple(value.shape) == space.shape, f"{where}: space {space.shape}, obs {tuple(value.shape)}"


@pytest.mark.parametrize("task", SMOKE_TASKS)
def test_task_builds_steps_resets_and_trains(task, tmp_path):
    env_cfg, _ = agile.tasks.load_cfgs(task)
    env_cfg.check_capture_safety = True  # the steps after the capture's warm-up: nothing the GPU's graph refuses
    for camera in env_cfg.scene.cameras.values():  # a recording task's camera, small: a CPU render per step
        camera.width, camera.height = 32, 24
    env = gym.make(task, cfg=env_cfg, num_envs=2, device="cpu").unwrapped
    obs, _ = env.reset()
    assert_in_space(env.observation_space, obs, "obs")
    for _ in range(5):
        obs, reward, terminated, truncated, extras = env.step(torch.rand(2, env.action_manager.total_action_dim) - 0.5)
        assert torch.isfinite(reward).all()
    # the env counts a NaN term as 0 in the reward: a finite reward alone would prove nothing
    assert not {name: int(n) for name, n in env.reward_manager.nonfinite_count.items() if int(n)}
    assert_in_space(env.observation_space, obs, "obs")
    assert_in_space(env.single_observation_space, obs[0], "obs[0]")
    obs, _ = env.reset()
    assert (env.episode_length_buf == 0).all()
    if "random_pos" in env.action_manager.active_terms:  # AGILE: only arms and head move randomly
        assert not [name for name in env.action_manager.get_term("random_pos").joint_names
                    if "waist" in name.lower() or "hip" in name.lower() or "knee" in name.lower()]

    _, agent_cfg = agile.tasks.load_cfgs(task)
    agent_cfg.num_steps_per_env = 4
    agent_cfg.algorithm.num_mini_batches = 2
    runner = OnPolicyRunner(RslRlVecEnvWrapper(env), to_rsl_rl_dict(agent_cfg), log_dir=str(tmp_path), device="cpu")
    runner.learn(num_learning_iterations=1)
    assert (tmp_path / "model_0.pt").is_file()
    if agent_cfg.algorithm.symmetry_cfg is not None:  # AGILE's lr-mirror, on the trainable tasks
        assert runner.alg.symmetry is not None and runner.alg.symmetry.use_data_augmentation
    env.close()


@pytest.mark.parametrize("task", MULTI_AGENT_SMOKE_TASKS)
def test_multi_agent_task_builds_steps_resets_and_trains(task, tmp_path):
    from agile.marl.runner import MultiAgentRunner

    world = gym.make(task, num_envs=2, device="cpu").unwrapped
    obs, _ = world.reset()
    for name, agent_obs in obs.items():
        assert_in_space(world.single_observation_spaces[name], agent_obs[0], f"obs['{name}'][0]")
    for _ in range(2 * len(world.schedule.slots)):
        dims = {a: world.agents[a].action_manager.total_action_dim for a in world.acting_agents}
        for name, step in world.step({a: torch.rand(2, d) - 0.5 for a, d in dims.items()}).items():
            assert torch.isfinite(step.reward).all(), name
    for name, agent in world.agents.items():  # a NaN term counts 0 in the reward: finite rewards alone prove nothing
        assert not {term: int(n) for term, n in agent.reward_manager.nonfinite_count.items() if int(n)}, name
    world.reset()
    assert all((a.episode_length_buf == 0).all() for a in world.agents.values())

    _, agent_cfg = agile.tasks.load_cfgs(task)
    agent_cfg.rollout_s = world.schedule.hyperperiod_steps * world.physics_dt_s * 2
    for group in agent_cfg.groups.values():
        group.runner.algorithm.num_mini_batches = 2
    runner = MultiAgentRunner(world, agent_cfg, str(tmp_path), "cpu")
    runner.learn(1)
    for group in agent_cfg.groups:
        assert (tmp_path / group / "model_0.pt").is_file()
