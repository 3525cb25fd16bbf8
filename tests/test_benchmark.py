"""benchmark.py's timing helpers on CPU (the figures themselves come from the GPU machine)."""

import torch
from benchmark import time_physics


def test_raw_physics_restarts_from_the_state_it_was_given(t1_env):
    robot = t1_env.scene["robot"]
    start_pose, start_joint_pos = robot.root_pose_w.clone(), robot.joint_pos.clone()
    rate = time_physics(t1_env.sim, t1_env.cfg.decimation, steps=6, chunk_steps=3)
    assert rate > 0.0
    # the robots moved while timed (spawn velocities), and were put back where they started
    torch.testing.assert_close(robot.root_pose_w, start_pose)
    torch.testing.assert_close(robot.joint_pos, start_joint_pos)
