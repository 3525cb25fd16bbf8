"""Torch rotation helpers. Quaternions are (x, y, z, w), the Newton/Warp layout, everywhere in agile."""

from __future__ import annotations

import math

import torch


def quat_rotate(q_xyzw: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    q_vec = q_xyzw[..., :3]
    w = q_xyzw[..., 3:4]
    t = 2.0 * torch.cross(q_vec, v, dim=-1)
    return v + w * t + torch.cross(q_vec, t, dim=-1)


def quat_rotate_inverse(q_xyzw: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate vectors v (..., 3) by the inverse of unit quaternions q (..., 4): world -> body frame."""
    q_vec = q_xyzw[..., :3]
    w = q_xyzw[..., 3:4]
    t = 2.0 * torch.cross(q_vec, v, dim=-1)
    return v - w * t + torch.cross(q_vec, t, dim=-1)


def world_to_heading_frame_xy(heading_rad: torch.Tensor, v_w: torch.Tensor) -> torch.Tensor:
    """(N, 2) planar world vectors v_w[:, :2] in the frame turned by `heading_rad` (N,) about z: x forward, y left."""
    cos, sin = torch.cos(heading_rad), torch.sin(heading_rad)
    return torch.stack((cos * v_w[:, 0] + sin * v_w[:, 1], -sin * v_w[:, 0] + cos * v_w[:, 1]), dim=1)


def quat_conjugate(q_xyzw: torch.Tensor) -> torch.Tensor:
    """The inverse rotation of a unit quaternion."""
    return torch.cat((-q_xyzw[..., :3], q_xyzw[..., 3:]), dim=-1)


def quat_mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    ax, ay, az, aw = a.unbind(-1)
    bx, by, bz, bw = b.unbind(-1)
    return torch.stack(
        (
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ),
        dim=-1,
    )


def quat_from_euler_xyz(roll: torch.Tensor, pitch: torch.Tensor, yaw: torch.Tensor) -> torch.Tensor:
    """Quaternion of the rotation Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = torch.cos(roll * 0.5), torch.sin(roll * 0.5)
    cp, sp = torch.cos(pitch * 0.5), torch.sin(pitch * 0.5)
    cy, sy = torch.cos(yaw * 0.5), torch.sin(yaw * 0.5)
    return torch.stack(
        (
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ),
        dim=-1,
    )


def yaw_from_quat(q_xyzw: torch.Tensor) -> torch.Tensor:
    x, y, z, w = q_xyzw.unbind(-1)
    return torch.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def wrap_to_pi(angle: torch.Tensor) -> torch.Tensor:
    return torch.remainder(angle + math.pi, 2.0 * math.pi) - math.pi


def rounded_list(values: torch.Tensor, digits: int = 6) -> list[float]:
    """A tensor's values as a flat list of floats rounded to `digits` (for YAML files such as IO descriptors)."""
    return [round(float(x), digits) for x in values.flatten().tolist()]
