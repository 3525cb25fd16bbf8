"""benchmark.py's and training_timing.py's timing helpers on CPU (the figures themselves come from the GPU machine)."""


import pytest
import torch
from agile.run.benchmark import restarter, slowest_world_solver_iterations, time_physics
from agile.run.training_timing import time_training_timeline


def test_raw_physics_restarts_from_the_state_it_was_given(t1_env):
    robot = t1_env.scene["robot"]
    start_pose, start_joint_pos = robot.root_pose_w.clone(), robot.joint_pos.clone()
    rate = time_physics(t1_env.sim, t1_env.cfg.decimation, steps=6, chunk_steps=3)
    assert rate > 0.0
    # the robots moved while timed (spawn velocities), and were put back where they started
    torch.testing.assert_close(robot.root_pose_w, start_pose)
    torch.testing.assert_close(robot.joint_pos, start_joint_pos)


def test_slowest_world_solver_iterations_lie_within_the_cap_and_restart_puts_the_world_back(t1_env):
    sim, robot = t1_env.sim, t1_env.scene["robot"]
    cap = sim.solver.mjw_model.opt.iterations
    start_joint_pos = robot.joint_pos.clone()
    iterations = slowest_world_solver_iterations(sim, lambda: sim.step(t1_env.cfg.decimation), steps=4,
                                                 restart=restarter(sim), chunk_steps=2)
    assert 1.0 <= iterations <= cap
    torch.testing.assert_close(robot.joint_pos, start_joint_pos)
    per_world = sim.solver_iterations()
    assert per_world.shape == (t1_env.num_envs,)
    assert int(per_world.min()) >= 1 and int(per_world.max()) <= cap


@pytest.mark.gpu
def test_the_gpu_timeline_splits_an_iteration_into_its_phases(tmp_path):
    """The unsynchronised timeline: every phase took GPU time, and the phases, measured on the GPU's clock from the
    first event to the last, add up to no more than the host's wall time of the same loop (plus the event's
    resolution)."""
    from agile.rl_env import ManagerBasedRLEnv
    from agile.rl.runner import training_runner
    from agile.run import task_setup

    env_cfg, agent_cfg, device = task_setup.load_task(task="Velocity-T1-v0", num_envs=64, device="cuda:0")
    env = ManagerBasedRLEnv(env_cfg, task_name="Velocity-T1-v0", device=device)
    runner = training_runner(env, agent_cfg, str(tmp_path))
    runner.learn(1)
    timeline = time_training_timeline(runner, runner.env, iterations=2)
    phases = ("act_s", "env_step_s", "storage_s", "returns_s", "update_s")
    assert all(timeline[phase] > 0.0 for phase in phases), timeline
    assert sum(timeline[phase] for phase in phases) <= timeline["loop_s"] + 1e-3, timeline


def test_the_gpu_timeline_is_for_cuda_only(t1_env):
    assert time_training_timeline(runner=None, env=t1_env, iterations=1) is None


def test_iteration_times_leave_out_the_run_ends_and_name_the_slowest_iteration():
    from agile.run.training_timing import iteration_times

    # logs at 1.0, 1.4, 1.8, 3.0 (a slow third interval: e.g. a checkpoint saved), 3.4 s
    times = iteration_times([1.0, 1.4, 1.8, 3.0, 3.4])
    assert times["iteration_s"] == pytest.approx(0.6)  # (3.4 - 1.0) / 4
    assert times["iteration_median_s"] == pytest.approx(0.4)
    assert times["iteration_slowest_s"] == pytest.approx(1.2) and times["iteration_slowest_of_run"] == 4
    with pytest.raises(ValueError, match="at least two"):
        iteration_times([1.0])


def test_whole_heap_collections_are_counted_and_timed_while_entered():
    import gc

    from agile.run.training_timing import FullGarbageCollections

    with FullGarbageCollections() as collections:
        gc.collect(1)  # a younger generation: not counted
        gc.collect()
    assert collections.count == 1 and collections.seconds > 0.0
    gc.collect()  # after the exit: not counted
    assert collections.count == 1
