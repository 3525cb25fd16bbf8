"""`reset_from_fallen_dataset` (AGILE): the reset event of a stand-up task."""

from __future__ import annotations

import math

import torch

from agile.tasks.stand_up.fallen_states.dataset import FallenStateDatasetCfg, FallenStates, load_or_collect
from agile.rl_env.managers import ManagerTermBase, SceneEntityCfg
from agile.utils.math import quat_from_euler_xyz, quat_mul

__all__ = ["reset_from_fallen_dataset"]


class reset_from_fallen_dataset(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """Each resetting env starts standing with probability `standing_ratio` (the default pose with a random yaw, at
    rest), else in a fallen state drawn from the dataset at the env's terrain row: the env moves to the cell (row,
    column) the state was collected in, and takes its root pose, velocities and joint state.

    The dataset (`dataset`: a FallenStateDatasetCfg, the default one when None) is loaded from its disk cache or
    collected when the env is built (`prepare`), before its first step; `set_dataset` hands over another. Masked
    tensor math only: safe inside the captured step.
    """

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        self.states: FallenStates | None = None

    def prepare(self, env) -> None:
        """Load the dataset from the cache or collect it, then reset the env: its first episodes start from it."""
        params = self.cfg.params
        dataset_cfg = params.get("dataset") or FallenStateDatasetCfg()
        robot_name = params["asset_cfg"].name if "asset_cfg" in params else "robot"
        self.set_dataset(load_or_collect(env, dataset_cfg, env.task_name, robot_name))
        env.reset()

    def set_dataset(self, states: FallenStates) -> None:
        if len(states) == 0:
            raise ValueError("the fallen-state dataset is empty (every world blew up while it was collected?)")
        self.states = states

    def __call__(self, env, env_mask: torch.Tensor, standing_ratio: float = 0.1,
                 dataset: FallenStateDatasetCfg | None = None, asset_cfg: SceneEntityCfg = SceneEntityCfg("robot")):
        robot = env.scene[asset_cfg.name]
        n, device = env.num_envs, env.device
        # the scene has just put these envs in the default pose at their origin: standing ones only turn
        yaw = (torch.rand(n, device=device) * 2.0 - 1.0) * math.pi
        zeros = torch.zeros(n, device=device)
        pose = robot.root_pose_w.clone()
        pose[:, 3:7] = quat_mul(quat_from_euler_xyz(zeros, zeros, yaw), pose[:, 3:7])
        if self.states is None:
            robot.write_root_state(pose, torch.zeros_like(robot.root_com_vel_w), env_mask)
            return
        standing = env_mask & (torch.rand(n, device=device) < standing_ratio)
        robot.write_root_state(pose, torch.zeros_like(robot.root_com_vel_w), standing)
        fallen = env_mask & ~standing
        index = self.states.sample(env.sim.terrain_levels)
        state = {name: value[index] for name, value in self.states.tensors.items()}
        env.sim.set_terrain_cells(state["level"], state["terrain_type"], fallen)
        fallen_pose = torch.cat((state["root_pos_env_m"] + env.env_origins, state["root_quat_xyzw"]), dim=1)
        robot.write_root_state(fallen_pose, state["root_vel_w"], fallen)
        robot.write_joint_state(state["joint_pos_rad"], state["joint_vel_radps"], fallen)
