"""benchmark.py's timing helpers on CPU (the figures themselves come from the GPU machine)."""

import torch
from agile.run.benchmark import restarter, slowest_world_solver_iterations, time_physics


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
