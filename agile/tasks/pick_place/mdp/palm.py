"""Pick-and-place frames: the reference command and the palm frame, a fixed offset from a body (AGILE: an `ee_frame`
FrameTransformer on the right palm)."""

from __future__ import annotations

import functools

import torch

from agile.rl_env.managers import SceneEntityCfg
from agile.utils.math import quat_rotate

__all__ = ["OBJECT", "offset_tensor", "palm_pose_w", "reference_command"]


OBJECT = SceneEntityCfg("object")


def reference_command(env, command_name: str):
    return env.command_manager.get_term(command_name)


# -- the palm frame: a fixed offset from a body (AGILE: an `ee_frame` FrameTransformer on the right palm) ---------

@functools.lru_cache(maxsize=16)
def offset_tensor(offset_m: tuple[float, float, float], device) -> torch.Tensor:
    """The offset on the device, made once: a captured step may not copy from the host."""
    return torch.tensor(offset_m, dtype=torch.float32, device=device)


def palm_pose_w(env, palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float]) -> tuple[torch.Tensor,
                                                                                                 torch.Tensor]:
    """(N, 3) position [m] and (N, 4) orientation (x, y, z, w) of the point `offset_m` in the frame of the first
    body of `palm_cfg`, world frame."""
    robot = env.scene[palm_cfg.name]
    pose = robot.body_pose_w[:, palm_cfg.body_ids].reshape(env.num_envs, -1, 7)[:, 0]
    offset = offset_tensor(tuple(offset_m), pose.device).expand(env.num_envs, 3)
    return pose[:, :3] + quat_rotate(pose[:, 3:7], offset), pose[:, 3:7]
