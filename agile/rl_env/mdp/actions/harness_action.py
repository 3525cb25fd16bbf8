"""Harness (AGILE `HarnessAction`): a spring-damper that holds a robot's base up and upright while it learns to
walk; a curriculum (`remove_harness`) scales it down to nothing. Training only: students and exported policies
run without it (`HarnessActionCfg.training_only`)."""

from __future__ import annotations

import torch
import warp as wp

from agile.rl_env.mdp.actions.body_wrench import BodyAidAction, write_body_wrench
from agile.rl_env.managers import ActionTermCfg
from agile.utils.config import configclass


@wp.func
def _clamp_vec(v: wp.vec3, limit: float) -> wp.vec3:
    return wp.vec3(wp.clamp(v[0], -limit, limit), wp.clamp(v[1], -limit, limit), wp.clamp(v[2], -limit, limit))


@wp.kernel
def _harness_wrench(body_q: wp.array(dtype=wp.transform), body_qd: wp.array(dtype=wp.spatial_vector),
                    body_ids: wp.array(dtype=wp.int32), target_height_m: wp.array(dtype=float),
                    ground_z_m: wp.array(dtype=float), scale: wp.array(dtype=float), stiffness_force: float,
                    damping_force: float, force_limit_n: float, stiffness_torque: float, damping_torque: float,
                    torque_limit_nm: float, disturbance_w: wp.array(dtype=wp.spatial_vector),
                    body_f: wp.array(dtype=wp.spatial_vector), last_total_w: wp.array(dtype=wp.spatial_vector)):
    i = wp.tid()
    b = body_ids[i]
    pose = body_q[b]
    quat = wp.transform_get_rotation(pose)
    height = wp.transform_get_translation(pose)[2] - ground_z_m[i]
    lin_vel = wp.spatial_top(body_qd[b])
    ang_vel_b = wp.quat_rotate_inv(quat, wp.spatial_bottom(body_qd[b]))
    # vertical spring-damper towards the target height above the terrain
    force_z = wp.clamp(stiffness_force * (target_height_m[i] - height) - damping_force * lin_vel[2],
                       -force_limit_n, force_limit_n)
    # tilt as a rotation vector in the body frame: the rotation that takes the world's up axis, seen from the
    # body, onto the body's z axis (about a horizontal body axis, so it has no yaw part whatever the heading)
    up_b = wp.quat_rotate_inv(quat, wp.vec3(0.0, 0.0, 1.0))
    axis = wp.vec3(up_b[1], -up_b[0], 0.0)
    sin_tilt = wp.length(axis)
    tilt = wp.atan2(sin_tilt, up_b[2])
    tilt_b = wp.vec3(0.0)
    if sin_tilt > 1.0e-9:
        tilt_b = axis * (tilt / sin_tilt)
    torque_b = _clamp_vec(-stiffness_torque * tilt_b - damping_torque * wp.vec3(ang_vel_b[0], ang_vel_b[1], 0.0),
                          torque_limit_nm)
    s = scale[0]
    harness = wp.spatial_vector(wp.vec3(0.0, 0.0, s * force_z), s * wp.quat_rotate(quat, torque_b))
    write_body_wrench(i, b, harness, disturbance_w, body_f, last_total_w)


class HarnessAction(BodyAidAction):
    """No policy output (action_dim 0). Before every physics step, a wrench on one body (the pelvis):
    - force along world z: clip(k_force·(h_target - h) - d_force·v_z, ±force_limit), h the body's height above
      the terrain under the height scanner `height_sensor` (the terrain height is the scan of the last env
      step, as AGILE's ray caster), h_target `target_height_m` or the height command (`command_name`, column 3);
    - torque about the body's x and y axes: clip(-k_torque·tilt - d_torque·ω_b,xy, ±torque_limit) per axis,
      tilt the body's roll/pitch rotation vector; no yaw;
    both times `scale` (1 at first; `remove_harness` lowers it; a (1,) device tensor, so that a captured step
    sees its changes).

    The solver applies `state.body_f` at every physics step, and random pushes (`apply_external_force_torque`)
    write it too. The body's wrench is therefore the push plus the harness: before each env step the push is
    recovered as what `body_f` holds if that is no longer what the harness wrote last (an event or a reset
    wrote a new push), else the previous push.
    """

    def __init__(self, cfg: HarnessActionCfg, env):
        super().__init__(cfg, env, "harness")
        self.command_name = cfg.command_name
        if cfg.command_name is not None:
            env.command_manager.get_term(cfg.command_name)  # a missing command is a build error
        n, device = env.num_envs, env.device
        self.target_height_m = torch.full((n,), cfg.target_height_m, device=device)
        state = env.sim.state
        slot = self.wrench_slot
        self.kernel = _harness_wrench
        self.kernel_inputs = [state.body_q, state.body_qd, slot.global_body_ids_wp, wp.from_torch(self.target_height_m),
                              self.terrain.ground_z_m_wp, wp.from_torch(self.scale),
                              cfg.stiffness_force_n_per_m, cfg.damping_force_n_s_per_m, cfg.force_limit_n,
                              cfg.stiffness_torque_nm_per_rad, cfg.damping_torque_nm_s_per_rad, cfg.torque_limit_nm,
                              slot.disturbance_w_wp, state.body_f, slot.last_total_w_wp]
        self.start_hook()

    def apply_actions(self) -> None:
        """Once per env step, before the physics: the targets, the terrain height, and the current push."""
        if self.command_name is not None:
            self.target_height_m.copy_(self.env.command_manager.get_command(self.command_name)[:, 3])
        self.terrain.update()
        self.wrench_slot.update_disturbance()


@configclass
class HarnessActionCfg(ActionTermCfg):
    """AGILE G1: k_torque 300, d_torque 50, k_force 1000, d_force 100, 150 N, 500 N·m, at 0.72 m or the
    commanded height."""

    class_type: type = HarnessAction
    body_name: str = "pelvis"
    stiffness_force_n_per_m: float = 1000.0
    damping_force_n_s_per_m: float = 100.0
    force_limit_n: float = 150.0
    stiffness_torque_nm_per_rad: float = 300.0
    damping_torque_nm_s_per_rad: float = 50.0
    torque_limit_nm: float = 500.0
    target_height_m: float = 0.72
    command_name: str | None = None
    """A height command term (column 3 of its command) to follow instead of `target_height_m`."""
    height_sensor: str | None = "height_measurement_sensor"
    """Height scanner under the body: the height is measured above the terrain it sees (None: above z=0)."""
    training_only: bool = True
    """An aid to learning, absent on the robot: students and exported policies drop every action term so marked."""
