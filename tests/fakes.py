"""A tiny stand-in for the env and robot, for hand-computed manager and term tests (no physics)."""

from __future__ import annotations

import torch

from agile.sim.entities.entity import body_yaw_in_frame
from agile.sim.names import resolve_names


class FakeRobot:
    def __init__(self, num_envs: int = 2, joint_names=("a", "b", "c"), body_names=("base", "foot_l", "foot_r")):
        n, j, b = num_envs, len(joint_names), len(body_names)
        self.num_envs, self.num_joints, self.num_bodies = n, j, b
        self.joint_names, self.body_names = list(joint_names), list(body_names)
        z = lambda *s: torch.zeros(*s)  # noqa: E731
        self.joint_pos, self.joint_vel, self.joint_acc = z(n, j), z(n, j), z(n, j)
        self.default_joint_pos, self.default_joint_vel = z(n, j), z(n, j)
        self.joint_pos_target = z(n, j)
        self.joint_pos_limits = torch.stack((-torch.ones(n, j), torch.ones(n, j)), dim=-1)
        self.soft_joint_pos_limits = self.joint_pos_limits.clone()
        self.joint_vel_limit = torch.full((n, j), 10.0)
        self.applied_torque, self.computed_torque = z(n, j), z(n, j)
        self.root_pos_w = z(n, 3)
        self.root_lin_vel_b, self.root_ang_vel_b = z(n, 3), z(n, 3)
        self.projected_gravity_b = torch.tensor([0.0, 0.0, -1.0]).repeat(n, 1)
        self.gravity_dir_w = torch.tensor([0.0, 0.0, -1.0]).expand(n, 3)
        self.heading_w = z(n)
        self.body_pose_w = z(n, b, 7)
        self.body_pose_w[..., 6] = 1.0

    def find_joints(self, exprs, preserve_order=False):
        return resolve_names(exprs, self.joint_names, "joint", preserve_order)

    def body_yaw_in_frame(self, body_ids, frame_body_ids):
        return body_yaw_in_frame(self.body_pose_w, body_ids, frame_body_ids)

    def find_bodies(self, exprs, preserve_order=False):
        return resolve_names(exprs, self.body_names, "body", preserve_order)


class FakeEnv:
    def __init__(self, num_envs: int = 2, **robot_kwargs):
        self.num_envs = num_envs
        self.device = torch.device("cpu")
        self.task_name = "Fake-v0"
        self.robot = FakeRobot(num_envs, **robot_kwargs)
        self.scene = {"robot": self.robot}
        self.max_episode_length_s = 10.0
        self.max_episode_length = 500
        self.episode_length_buf = torch.zeros(num_envs, dtype=torch.long)
        self.common_step_counter = 0
        self.env_origins = torch.zeros(num_envs, 3)
