"""Quaternion functions for Warp kernels, (x, y, z, w) as in `agile.utils.math`, each written with that module's
arithmetic term by term (so a kernel and the torch function it stands for agree to the rounding of the functions
they call: sin, cos, atan2 and sqrt of torch's CPU kernels are not all correctly rounded)."""

from __future__ import annotations

import warp as wp


@wp.func
def quat_mul(a: wp.vec4, b: wp.vec4) -> wp.vec4:
    """a * b (`math.quat_mul`)."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    return wp.vec4(aw * bx + ax * bw + ay * bz - az * by,
                   aw * by - ax * bz + ay * bw + az * bx,
                   aw * bz + ax * by - ay * bx + az * bw,
                   aw * bw - ax * bx - ay * by - az * bz)


@wp.func
def quat_from_euler_xyz(roll: float, pitch: float, yaw: float) -> wp.vec4:
    """The rotation Rz(yaw) Ry(pitch) Rx(roll) (`math.quat_from_euler_xyz`)."""
    cr, sr = wp.cos(roll * 0.5), wp.sin(roll * 0.5)
    cp, sp = wp.cos(pitch * 0.5), wp.sin(pitch * 0.5)
    cy, sy = wp.cos(yaw * 0.5), wp.sin(yaw * 0.5)
    return wp.vec4(sr * cp * cy - cr * sp * sy,
                   cr * sp * cy + sr * cp * sy,
                   cr * cp * sy - sr * sp * cy,
                   cr * cp * cy + sr * sp * sy)


@wp.func
def rotate_inverse(q_vec: wp.vec3, q_w: float, v: wp.vec3) -> wp.vec3:
    """v rotated by the inverse of the unit quaternion (q_vec, q_w): world -> body frame
    (`math.quat_rotate_inverse`)."""
    t = 2.0 * wp.cross(q_vec, v)
    return v - q_w * t + wp.cross(q_vec, t)


@wp.func
def yaw_of(x: float, y: float, z: float, w: float) -> float:
    """The yaw of a unit quaternion (x, y, z, w) [rad] (`math.yaw_from_quat`)."""
    return wp.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
