"""Reading a `MotionCommand`'s reference: the command term, tracked-body columns, orientation errors."""

from __future__ import annotations

import functools

import torch

from agile.utils.math import quat_conjugate, quat_mul, quat_rotate

__all__ = ["body_columns", "column_ids", "first_two_columns", "motion_command", "quat_error_magnitude"]


def motion_command(env, command_name: str):
    return env.command_manager.get_term(command_name)


def body_columns(command, body_names: list[str] | None) -> torch.Tensor | slice:
    """Columns of `body_names` among the command's tracked bodies (all when None), as a device index tensor made
    once per name list: a captured step may not copy from the host."""
    if body_names is None:
        return slice(None)
    return column_ids(tuple(command.body_names), tuple(body_names), command.body_pos_relative_w.device)


@functools.lru_cache(maxsize=64)
def column_ids(tracked: tuple[str, ...], body_names: tuple[str, ...], device) -> torch.Tensor:
    missing = [n for n in body_names if n not in tracked]
    if missing:
        raise ValueError(f"bodies {missing} are not tracked by the motion command. Tracked: {list(tracked)}")
    return torch.tensor([tracked.index(n) for n in body_names], dtype=torch.long, device=device)


def quat_error_magnitude(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Angle [rad] of the rotation between unit quaternions a and b, in [0, π]."""
    diff = quat_mul(a, quat_conjugate(b))
    return 2.0 * torch.atan2(torch.linalg.norm(diff[..., :3], dim=-1), diff[..., 3].abs())


def first_two_columns(q_xyzw: torch.Tensor) -> torch.Tensor:
    """(..., 6) the first two columns of the rotation matrix of q, row by row (BeyondMimic's 6-D orientation)."""
    x_axis = torch.zeros_like(q_xyzw[..., :3])
    x_axis[..., 0] = 1.0
    y_axis = torch.zeros_like(x_axis)
    y_axis[..., 1] = 1.0
    columns = torch.stack([quat_rotate(q_xyzw, x_axis), quat_rotate(q_xyzw, y_axis)], dim=-1)  # (..., 3, 2)
    return columns.flatten(-2)
