"""Contacts of collision shapes against the terrain height field, computed from the height samples directly.

Newton's general collision pipeline treats the height field as a triangle mesh: a midphase over the triangles
near each shape, a convex test per triangle, then contact reduction. On the registered rough tasks that is most
of a physics step (`../shared/reference/terrain_profile_h200.md`: 3.2 ms per step with robots up, 13.7 ms with
robots lying down, against 2.4 ms for the whole solver step). A robot's colliders are primitives, and what the
solver needs from the terrain is a few points per collider, as MuJoCo's own plane collision gives them:

- probe points: a sphere's centre, a capsule's two end centres (with the radius), a box's eight corners, a
  cylinder's three lowest points on each cap rim; each against the triangle under it (the surface normal and
  height of that triangle, split as `heightfield_cell` splits a cell);
- height samples inside a box: a ridge or bump under a sole (the box-grid terrains) pushes on the face it
  entered through, which corner probes alone would miss.

One thread per probe or per sample candidate, a fixed launch size, no broadphase: the cost does not grow with
the number of triangles a shape overlaps. Contacts are appended to a `newton.Contacts` buffer in Newton's
layout (body-frame points, offsets along the normal, margins), so SolverMuJoCo and the contact sensors read them
as they read the pipeline's. Contacts beyond the buffer are counted in `dropped_contacts`, never written.
"""

from __future__ import annotations

import math

import newton
import numpy as np
import warp as wp

from agile.sim.terrain import TerrainData

SUPPORTED_TYPES = {int(newton.GeoType.SPHERE): 1, int(newton.GeoType.CAPSULE): 2, int(newton.GeoType.BOX): 8,
                   int(newton.GeoType.CYLINDER): 6}
"""Collider types this module collides with the terrain, and their number of probe points."""
PROBES_PER_SHAPE = 8

SPHERE = wp.constant(int(newton.GeoType.SPHERE))
CAPSULE = wp.constant(int(newton.GeoType.CAPSULE))
BOX = wp.constant(int(newton.GeoType.BOX))
CYLINDER = wp.constant(int(newton.GeoType.CYLINDER))


@wp.func
def _shape_pose(shape: int, body_q: wp.array(dtype=wp.transform), shape_body: wp.array(dtype=int),
                shape_transform: wp.array(dtype=wp.transform)) -> wp.transform:
    body = shape_body[shape]
    if body < 0:
        return shape_transform[shape]
    return wp.transform_multiply(body_q[body], shape_transform[shape])


@wp.func
def heightfield_cell(heights: wp.array2d(dtype=float), origin_x_m: float, origin_y_m: float, spacing_m: float,
                     x_m: float, y_m: float):
    """(i, j, fu, fv): the height-field cell under (x, y) and the fractions of the way across it; outside the grid,
    the edge cell (the border is flat). A cell is two triangles split along the diagonal from (i, j+1) to (i+1, j),
    as MuJoCo builds its height-field prisms: fu + fv <= 1 is the one with (i, j)."""
    u = wp.clamp((x_m - origin_x_m) / spacing_m, 0.0, float(heights.shape[0]) - 1.0001)
    v = wp.clamp((y_m - origin_y_m) / spacing_m, 0.0, float(heights.shape[1]) - 1.0001)
    i = wp.floor(u)
    j = wp.floor(v)
    return int(i), int(j), u - i, v - j


@wp.func
def _triangle_under(heights: wp.array2d(dtype=float), origin: wp.vec2, spacing: float, p: wp.vec3):
    """A vertex and the upward unit normal of the height-field triangle under p (outside the grid, the edge cell)."""
    i, j, fu, fv = heightfield_cell(heights, origin[0], origin[1], spacing, p[0], p[1])
    x0 = origin[0] + float(i) * spacing
    y0 = origin[1] + float(j) * spacing
    z01 = heights[i, j + 1]
    z10 = heights[i + 1, j]
    if fu + fv <= 1.0:
        z00 = heights[i, j]
        vertex = wp.vec3(x0, y0, z00)
        normal = wp.vec3(-(z10 - z00) / spacing, -(z01 - z00) / spacing, 1.0)
    else:
        z11 = heights[i + 1, j + 1]
        vertex = wp.vec3(x0 + spacing, y0 + spacing, z11)
        normal = wp.vec3(-(z11 - z01) / spacing, -(z11 - z10) / spacing, 1.0)
    return vertex, wp.normalize(normal)


@wp.func
def _probe(shape_type: int, scale: wp.vec3, pose: wp.transform, slot: int):
    """World position and radius of a shape's probe `slot`; radius < 0 when the shape has no such probe."""
    centre = wp.transform_get_translation(pose)
    rot = wp.transform_get_rotation(pose)
    radius = float(-1.0)
    point = centre
    if shape_type == SPHERE:
        if slot == 0:
            radius = scale[0]
    elif shape_type == CAPSULE:
        if slot < 2:
            sign = 1.0 - 2.0 * float(slot)
            point = centre + wp.quat_rotate(rot, wp.vec3(0.0, 0.0, sign * scale[1]))
            radius = scale[0]
    elif shape_type == BOX:
        sx = 1.0 - 2.0 * float(slot & 1)
        sy = 1.0 - 2.0 * float((slot >> 1) & 1)
        sz = 1.0 - 2.0 * float((slot >> 2) & 1)
        point = centre + wp.quat_rotate(rot, wp.vec3(sx * scale[0], sy * scale[1], sz * scale[2]))
        radius = 0.0
    elif shape_type == CYLINDER:
        if slot < 6:
            # each cap's lowest rim point (towards -z) and the two at +-120 degrees from it: a tripod that
            # holds an upright cylinder and a line of contact for one lying down
            cap = slot / 3
            sign = 1.0 - 2.0 * float(cap)
            axis = wp.quat_rotate(rot, wp.vec3(0.0, 0.0, 1.0))
            down = wp.vec3(0.0, 0.0, -1.0)
            lowest = down - wp.dot(down, axis) * axis
            if wp.length(lowest) < 1.0e-4:  # upright: any direction across the axis
                lowest = wp.quat_rotate(rot, wp.vec3(1.0, 0.0, 0.0))
            lowest = wp.normalize(lowest)
            side = wp.cross(axis, lowest)
            angle = 2.0943951 * float(slot - 3 * cap)  # 0, 120 or 240 degrees
            rim = wp.cos(angle) * lowest + wp.sin(angle) * side
            point = centre + sign * scale[1] * axis + scale[0] * rim
            radius = 0.0
    return point, radius


@wp.struct
class _ContactBuffer:
    """A `newton.Contacts` buffer's rigid-contact arrays, its counter and our count of contacts that found it full."""

    contact_max: int
    contact_count: wp.array(dtype=wp.int32)
    dropped: wp.array(dtype=wp.int32)
    shape0: wp.array(dtype=wp.int32)
    shape1: wp.array(dtype=wp.int32)
    point0: wp.array(dtype=wp.vec3)
    point1: wp.array(dtype=wp.vec3)
    offset0: wp.array(dtype=wp.vec3)
    offset1: wp.array(dtype=wp.vec3)
    normal: wp.array(dtype=wp.vec3)
    margin0: wp.array(dtype=wp.float32)
    margin1: wp.array(dtype=wp.float32)
    tids: wp.array(dtype=wp.int32)


@wp.func
def _append(out: _ContactBuffer, shape: int, terrain_shape: int, body: int, body_q: wp.array(dtype=wp.transform),
            core_w: wp.vec3, surface_w: wp.vec3, normal: wp.vec3, radius: float, margin0: float, margin1: float):
    """Append one contact in Newton's layout: shape0's core point (a sphere's centre) in its body frame with the
    offset to its surface, the terrain's point in the world frame (the terrain has no body), the normal from shape0
    to the terrain, each side's thickness (radius + shape margin). A full buffer counts the contact as dropped."""
    index = wp.atomic_add(out.contact_count, 0, 1)
    if index >= out.contact_max:
        wp.atomic_add(out.dropped, 0, 1)
        return
    to_body = wp.transform_identity()
    if body >= 0:
        to_body = wp.transform_inverse(body_q[body])
    thickness0 = radius + margin0
    out.shape0[index] = shape
    out.shape1[index] = terrain_shape
    out.point0[index] = wp.transform_point(to_body, core_w)
    out.point1[index] = surface_w
    out.offset0[index] = wp.transform_vector(to_body, thickness0 * normal)
    out.offset1[index] = -margin1 * normal
    out.normal[index] = normal
    out.margin0[index] = thickness0
    out.margin1[index] = margin1
    out.tids[index] = 0


@wp.kernel(enable_backward=False)
def _probe_contacts(
    shape_ids: wp.array(dtype=int), body_q: wp.array(dtype=wp.transform), shape_body: wp.array(dtype=int),
    shape_transform: wp.array(dtype=wp.transform), shape_type: wp.array(dtype=int),
    shape_scale: wp.array(dtype=wp.vec3), shape_margin: wp.array(dtype=float), shape_gap: wp.array(dtype=float),
    heights: wp.array2d(dtype=float), origin: wp.vec2, spacing: float, terrain_shape: int, out: _ContactBuffer,
):
    k, slot = wp.tid()
    shape = shape_ids[k]
    pose = _shape_pose(shape, body_q, shape_body, shape_transform)
    point, radius = _probe(shape_type[shape], shape_scale[shape], pose, slot)
    if radius < 0.0:
        return
    vertex, up = _triangle_under(heights, origin, spacing, point)
    above = wp.dot(point - vertex, up)  # of the probe's centre over the triangle's plane
    separation = above - radius
    if separation > shape_gap[shape] + shape_gap[terrain_shape]:
        return
    _append(out, shape, terrain_shape, shape_body[shape], body_q, point, point - above * up, -up, radius,
            shape_margin[shape], shape_margin[terrain_shape])


@wp.kernel(enable_backward=False)
def _box_sample_contacts(
    box_ids: wp.array(dtype=int), window: int, body_q: wp.array(dtype=wp.transform), shape_body: wp.array(dtype=int),
    shape_transform: wp.array(dtype=wp.transform), shape_scale: wp.array(dtype=wp.vec3),
    shape_margin: wp.array(dtype=float), shape_gap: wp.array(dtype=float),
    heights: wp.array2d(dtype=float), origin: wp.vec2, spacing: float, terrain_shape: int, out: _ContactBuffer,
):
    k, cell = wp.tid()
    shape = box_ids[k]
    pose = _shape_pose(shape, body_q, shape_body, shape_transform)
    half = shape_scale[shape]
    centre = wp.transform_get_translation(pose)
    # the height samples under the box's bounding circle; `window` samples a side covers any orientation
    reach = wp.length(half)
    i = int(wp.ceil((centre[0] - reach - origin[0]) / spacing)) + cell % window
    j = int(wp.ceil((centre[1] - reach - origin[1]) / spacing)) + cell / window
    if i < 0 or j < 0 or i >= heights.shape[0] or j >= heights.shape[1]:
        return
    sample = wp.vec3(origin[0] + float(i) * spacing, origin[1] + float(j) * spacing, heights[i, j])
    local = wp.transform_point(wp.transform_inverse(pose), sample)
    gap = shape_gap[shape] + shape_gap[terrain_shape]
    # depth of the sample behind each face: inside the box when every depth is positive (the face it is least deep
    # behind takes the contact); a speculative contact when it is outside one face only, by less than the gap (over
    # an edge or a corner it is left to the corner probes)
    best_axis = int(-1)
    best_sign = float(0.0)
    best_depth = float(1.0e6)
    outside = int(0)
    for axis in range(3):
        for side in range(2):
            sign = 1.0 - 2.0 * float(side)
            depth = half[axis] - sign * local[axis]
            if depth < -gap:
                return
            if depth < 0.0:
                outside += 1
            if depth < best_depth:
                best_depth = depth
                best_axis = axis
                best_sign = sign
    if outside > 1:
        return
    face_local = wp.vec3(local[0], local[1], local[2])
    face_local[best_axis] = best_sign * half[best_axis]
    face_normal = wp.vec3(0.0)
    face_normal[best_axis] = best_sign
    face_w = wp.transform_point(pose, face_local)
    normal = wp.quat_rotate(wp.transform_get_rotation(pose), face_normal)
    _append(out, shape, terrain_shape, shape_body[shape], body_q, face_w, sample, normal, 0.0,
            shape_margin[shape], shape_margin[terrain_shape])


class TerrainContacts:
    """Appends the contacts of `shape_ids` against the terrain to a `newton.Contacts` buffer every physics step."""

    def __init__(self, model: newton.Model, terrain: TerrainData, terrain_shape: int, shape_ids: list[int],
                 contacts: newton.Contacts):
        types = model.shape_type.numpy()
        labels = model.shape_label
        unsupported = sorted({f"{labels[s]} ({newton.GeoType(int(types[s])).name})" for s in shape_ids
                              if int(types[s]) not in SUPPORTED_TYPES})
        if unsupported:
            names = ", ".join(newton.GeoType(t).name.lower() for t in SUPPORTED_TYPES)
            raise ValueError(f"scene.terrain_collision='probes' collides {names} colliders with the terrain; these "
                             f"shapes are not: {unsupported[:5]} (use scene.terrain_collision='newton_pipeline')")
        self.model = model
        self.contacts = contacts
        self.terrain_shape = terrain_shape
        device = model.device
        self._heights = wp.array(np.ascontiguousarray(terrain.heights_m, dtype=np.float32), dtype=float, device=device)
        self._origin = wp.vec2(*terrain.origin_xy_m)
        self._spacing = float(terrain.horizontal_scale_m)
        self._shape_ids = wp.array(np.asarray(shape_ids, dtype=np.int32), dtype=int, device=device)
        boxes = [s for s in shape_ids if int(types[s]) == int(newton.GeoType.BOX)]
        self._box_ids = wp.array(np.asarray(boxes, dtype=np.int32), dtype=int, device=device)
        scales = model.shape_scale.numpy()
        # samples a side of the window that covers a box's bounding circle at any position: 2 reach / spacing + 1
        self._window = max((math.floor(2 * float(np.linalg.norm(scales[s])) / self._spacing) + 2 for s in boxes),
                           default=0)
        self._dropped = wp.zeros(1, dtype=wp.int32, device=device)
        self.dropped_contacts = wp.to_torch(self._dropped)
        """(1,) int32: contacts that found the buffer full since the start (not written; raise nconmax)."""
        self._out = self._buffer()

    def _buffer(self) -> _ContactBuffer:
        c = self.contacts
        out = _ContactBuffer()
        out.contact_max = c.rigid_contact_max
        out.contact_count, out.dropped = c.rigid_contact_count, self._dropped
        out.shape0, out.shape1 = c.rigid_contact_shape0, c.rigid_contact_shape1
        out.point0, out.point1 = c.rigid_contact_point0, c.rigid_contact_point1
        out.offset0, out.offset1 = c.rigid_contact_offset0, c.rigid_contact_offset1
        out.normal, out.margin0, out.margin1 = c.rigid_contact_normal, c.rigid_contact_margin0, c.rigid_contact_margin1
        out.tids = c.rigid_contact_tids
        return out

    def collide(self, state: newton.State) -> None:
        """Append this step's terrain contacts after those already in the buffer (clear it first)."""
        m = self.model
        terrain = [self._heights, self._origin, self._spacing, self.terrain_shape, self._out]
        if self._shape_ids.shape[0]:
            wp.launch(_probe_contacts, dim=(self._shape_ids.shape[0], PROBES_PER_SHAPE), device=m.device,
                      inputs=[self._shape_ids, state.body_q, m.shape_body, m.shape_transform, m.shape_type,
                              m.shape_scale, m.shape_margin, m.shape_gap, *terrain])
        if self._box_ids.shape[0]:
            wp.launch(_box_sample_contacts, dim=(self._box_ids.shape[0], self._window * self._window),
                      device=m.device,
                      inputs=[self._box_ids, self._window, state.body_q, m.shape_body, m.shape_transform,
                              m.shape_scale, m.shape_margin, m.shape_gap, *terrain])


def split_terrain_pairs(model: newton.Model, terrain_shape: int) -> tuple[list[int], np.ndarray]:
    """The shapes that may touch the terrain (from the model's candidate contact pairs) and the other pairs."""
    pairs = model.shape_contact_pairs.numpy() if model.shape_contact_pairs is not None else np.zeros((0, 2), int)
    with_terrain = (pairs == terrain_shape).any(axis=1)
    shapes = np.where(pairs[with_terrain, 0] == terrain_shape, pairs[with_terrain, 1], pairs[with_terrain, 0])
    return sorted(int(s) for s in shapes), pairs[~with_terrain]

