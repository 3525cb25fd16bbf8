"""Lift (AGILE `LiftAction`, stand-up): a force that pulls a fallen robot up by one link (T1: the head, "H2")
towards a target height that rises over the episode, with yaw damping; a curriculum (`adaptive_lift_curriculum`)
weakens it as the policy learns to stand up by itself. Training only: students and exported policies run without
it (`LiftActionCfg.training_only`)."""

from __future__ import annotations

import torch
import warp as wp

from agile.rl_env.mdp.actions.body_wrench import BodyAidAction, BodyWrenchSlot, write_body_wrench
from agile.rl_env.managers import ActionTermCfg
from agile.utils.config import configclass

__all__ = ["LiftAction", "LiftActionCfg"]


@wp.kernel
def _lift_wrench(root_z_w_m: wp.array(dtype=float), root_lin_vel_z_w: wp.array(dtype=float),
                 root_ang_vel_z_w: wp.array(dtype=float), body_q: wp.array(dtype=wp.transform),
                 point_body_ids: wp.array(dtype=wp.int32), point_offset_b_m: wp.vec3, measure_point: int,
                 ground_z_m: wp.array(dtype=float), target_height_m: wp.array(dtype=float),
                 force_gate: wp.array(dtype=float), scale: wp.array(dtype=float), stiffness_force: float,
                 damping_force: float, force_limit_n: float, allow_push_down: int, damping_torque: float,
                 torque_limit_nm: float, body_ids: wp.array(dtype=wp.int32),
                 disturbance_w: wp.array(dtype=wp.spatial_vector), body_f: wp.array(dtype=wp.spatial_vector),
                 last_total_w: wp.array(dtype=wp.spatial_vector), max_heights_m: wp.array(dtype=float),
                 yaw_body_ids: wp.array(dtype=wp.int32), yaw_disturbance_w: wp.array(dtype=wp.spatial_vector),
                 yaw_last_total_w: wp.array(dtype=wp.spatial_vector), yaw_on_lifted_body: int):
    i = wp.tid()
    height_m = root_z_w_m[i] - ground_z_m[i]
    if measure_point != 0:  # the height command's tracked point (a body point) instead of the root
        height_m = wp.transform_point(body_q[point_body_ids[i]], point_offset_b_m)[2] - ground_z_m[i]
    # tracked even while the lift is off: the curriculum judges standing by it
    max_heights_m[i] = wp.max(max_heights_m[i], height_m)
    # AGILE's scale_forces scales the gains and the limits alike
    s = scale[0]
    force_limit = s * force_limit_n
    torque_limit = s * torque_limit_nm
    # lift only (T1): a robot above the target is not pulled down; with allow_push_down it is, as hard as it is lifted
    lowest_force = 0.0
    if allow_push_down != 0:
        lowest_force = -force_limit
    force_pd = s * (stiffness_force * (target_height_m[i] - height_m) - damping_force * root_lin_vel_z_w[i])
    force_z = force_gate[i] * wp.clamp(force_pd, lowest_force, force_limit)
    # yaw damping only: roll and pitch stay free for the robot to balance
    torque_z = wp.clamp(-s * damping_torque * root_ang_vel_z_w[i], -torque_limit, torque_limit)
    if yaw_on_lifted_body != 0:
        lift = wp.spatial_vector(wp.vec3(0.0, 0.0, force_z), wp.vec3(0.0, 0.0, torque_z))
        write_body_wrench(i, body_ids[i], lift, disturbance_w, body_f, last_total_w)
    else:
        write_body_wrench(i, body_ids[i], wp.spatial_vector(wp.vec3(0.0, 0.0, force_z), wp.vec3(0.0)),
                          disturbance_w, body_f, last_total_w)
        write_body_wrench(i, yaw_body_ids[i], wp.spatial_vector(wp.vec3(0.0), wp.vec3(0.0, 0.0, torque_z)),
                          yaw_disturbance_w, body_f, yaw_last_total_w)


class LiftAction(BodyAidAction):
    """No policy output (action_dim 0). Before every physics step, a wrench in the world frame on one link
    (`body_name`, T1's head "H2"), as AGILE's `LiftAction.apply_actions` (which Isaac Lab calls every physics step):
    - h: the root height above the terrain, root z (at this physics step) minus the mean terrain height under the
      height scanner `height_sensor` (AGILE re-casts its rays every physics step; here the scan of the last env
      step, under a root that moves little within one); `max_heights_m` keeps its maximum over the episode;
    - target: clamp((t - start_lifting_time_s) / lifting_duration_s, 0, 1) · target_height_m, t the episode time
      (episode_length_buf · step_dt, as AGILE: fixed within an env step); 0 until start_lifting_time_s;
    - force along world z: clamp(k_force·(target - h), 0, force_limit_n): it lifts, never pushes down;
    - following a height command (`height_command`, AGILE's HeightTracking-G1): h is the height of the command's
      tracked point (its body's pose at this physics step, plus its offset), the target the command; with
      `vertical_damping` the force is k_force·(target - h) - d_force·v_z (v_z the root's vertical velocity),
      with `allow_push_down` clamped to ±limit, with `force_limit_weight_fraction` the limit a share of the
      robot's weight; the force is 0 while the command is negative;
    - torque about world z: clamp(-d_torque·ω_z, ±torque_limit_nm), ω_z the root's yaw rate: no roll or pitch;
      on `yaw_damping_body_name` (default the root: see the config field for why not the lifted link);
    k_force, d_torque and both limits times `scale` (1 at first; the curriculum lowers it through `scale_forces`;
    a (1,) device tensor, so that a captured step sees its changes). AGILE's `damping_forces` (d_force) is
    configured but not used by its lift: no vertical damping.

    Random pushes on the same link add to the lift (`BodyWrenchSlot`, as the harness).

    The yaw damping is explicit (from the yaw rate before the physics step), so it is stable only while
    d_torque·physics_dt < 2·I_yaw of the body it acts on and what holds to it: lying down T1 is far inside that,
    but upright (I_yaw about 0.5 kg·m² rigid, less with its joints compliant) AGILE's 100 N·m·s/rad at 5 ms
    overshoots and flips the spin each physics step (measured on CPU: 1 → -2.0 → 4.1 rad/s), bounded by the torque
    limit, until the curriculum lowers the scale.
    """

    def __init__(self, cfg: LiftActionCfg, env):
        if not cfg.lifting_duration_s > 0.0:
            raise ValueError(f"lift lifting_duration_s must be positive, got {cfg.lifting_duration_s}")
        fraction = cfg.force_limit_weight_fraction
        if fraction is not None and not fraction > 0.0:
            raise ValueError(f"lift force_limit_weight_fraction must be positive (or None), got {fraction}")
        super().__init__(cfg, env, "lift")
        n, device = env.num_envs, env.device
        self.target_height_m = torch.zeros(n, device=device)
        """(N,) the lift's target height above the terrain for the current env step [m]."""
        self.force_gate = torch.ones(n, device=device)
        """(N,) 1 where the lift pushes this env step, 0 where it does not (a negative height command)."""
        self.height_command = None
        point_body_id, point_offset_b_m = 0, (0.0, 0.0, 0.0)
        if cfg.height_command is not None:
            # follow the command: its target, measured at its tracked point (AGILE: `command.measured_height`)
            self.height_command = env.command_manager.get_term(cfg.height_command)
            point_body_id, point_offset_b_m = self.height_command.body_id, self.height_command.cfg.offset_b_m
        self.force_limit_n = cfg.force_limit_n
        """Force limit at scale 1 [N]: `force_limit_n`, or the fraction of the robot's weight (its masses as built,
        mean over the envs, as AGILE)."""
        if fraction is not None:
            mass_kg = self.robot.body_mass.sum(dim=1).mean().item()  # once, at construction
            self.force_limit_n = fraction * mass_kg * abs(env.cfg.sim.gravity_mps2)
        point_slot = BodyWrenchSlot(env, self.robot, point_body_id)
        damping_force = cfg.damping_force_n_s_per_m if cfg.vertical_damping else 0.0
        self.max_heights_m = torch.zeros(n, device=device)
        """(N,) highest root height above the terrain in the current episode [m] (AGILE `max_heights`), over
        every physics step; 0 at the episode's start. The curriculum counts an episode as standing by it."""
        slot = self.wrench_slot
        yaw_body_id = self._yaw_body_id(cfg)
        yaw_on_lifted_body = yaw_body_id == self.body_id
        self.yaw_wrench_slot = slot if yaw_on_lifted_body else BodyWrenchSlot(env, self.robot, yaw_body_id)
        yaw = self.yaw_wrench_slot
        # the root's height and yaw rate, read in place from the simulation state at every physics step
        self.kernel = _lift_wrench
        self.kernel_inputs = [wp.from_torch(self.robot.root_pos_w[:, 2]), wp.from_torch(self.robot.root_lin_vel_w[:, 2]),
                              wp.from_torch(self.robot.root_ang_vel_w[:, 2]), env.sim.state.body_q,
                              point_slot.global_body_ids_wp, wp.vec3(*point_offset_b_m),
                              int(self.height_command is not None), self.terrain.ground_z_m_wp,
                              wp.from_torch(self.target_height_m), wp.from_torch(self.force_gate),
                              wp.from_torch(self.scale), cfg.stiffness_force_n_per_m, damping_force, self.force_limit_n,
                              int(cfg.allow_push_down), cfg.damping_torque_nm_s_per_rad,
                              cfg.torque_limit_nm, slot.global_body_ids_wp, slot.disturbance_w_wp, env.sim.state.body_f,
                              slot.last_total_w_wp, wp.from_torch(self.max_heights_m), yaw.global_body_ids_wp,
                              yaw.disturbance_w_wp, yaw.last_total_w_wp, int(yaw_on_lifted_body)]
        self.start_hook()

    def _yaw_body_id(self, cfg) -> int:
        if cfg.yaw_damping_body_name is None:
            return 0  # the root body
        ids, names = self.robot.find_bodies(cfg.yaw_damping_body_name)
        if len(ids) != 1:
            raise ValueError(f"lift yaw_damping_body_name '{cfg.yaw_damping_body_name}' must match one body, "
                             f"matched {names}")
        return ids[0]

    def apply_actions(self) -> None:
        """Once per env step, before the physics: the target height, the terrain height, and the current push."""
        cfg = self.cfg
        if self.height_command is not None:
            target_m = self.height_command.target_height_m
            self.target_height_m.copy_(target_m)
            # a negative command asks the robot to lie relaxed: a posture, not a height the lift could hold
            self.force_gate.copy_((target_m >= 0.0).float())
        else:
            elapsed_s = self.env.episode_length_buf * self.env.step_dt
            progress = ((elapsed_s - cfg.start_lifting_time_s) / cfg.lifting_duration_s).clamp(0.0, 1.0)
            self.target_height_m.copy_(progress * cfg.target_height_m)
        self.terrain.update()
        self.wrench_slot.update_disturbance()
        if self.yaw_wrench_slot is not self.wrench_slot:
            self.yaw_wrench_slot.update_disturbance()

    def reset(self, env_mask: torch.Tensor) -> None:
        """A new episode: its highest height starts again from 0 (AGILE)."""
        self.max_heights_m.masked_fill_(env_mask, 0.0)


@configclass
class LiftActionCfg(ActionTermCfg):
    """AGILE T1 stand-up: on the head ("H2"), k_force 5000, d_force 500 (unused), 300 N, d_torque 100, 250 N·m,
    to 0.65 m (T1's standing trunk height) from 3 s over 10 s."""

    class_type: type = LiftAction
    body_name: str = "H2"
    """The link pulled up (AGILE `link_to_lift`)."""
    stiffness_force_n_per_m: float = 5000.0
    damping_force_n_s_per_m: float = 500.0
    """AGILE's `damping_forces`: the T1 lift (FEB26) configures it but applies no vertical damping, so it is
    used only with `vertical_damping`."""
    vertical_damping: bool = False
    """Damp the root's vertical velocity: F_z = k·(target - h) - d·v_z (the height-tracking lift); off: F_z =
    k·(target - h) (AGILE T1)."""
    force_limit_n: float = 300.0
    force_limit_weight_fraction: float | None = None
    """If set, the force limit is this fraction of the robot's weight (Σ body masses · g) instead of
    `force_limit_n` (AGILE HeightTracking-G1: 0.9)."""
    allow_push_down: bool = False
    """Let the force point down too (clamped to ±limit): a robot above its target is pushed down to it."""
    height_command: str | None = None
    """A height command term (`SmoothHeightCommand`) to follow instead of the time ramp: the target is its
    command, the height that of its tracked point (not the root), and the force is off while the command is
    negative (a request to lie relaxed)."""
    damping_torque_nm_s_per_rad: float = 100.0
    torque_limit_nm: float = 250.0
    yaw_damping_body_name: str | None = None
    """The body the yaw-damping torque acts on; None: the root (the body whose yaw rate it damps). AGILE puts it on
    the lifted link, which on T1 is the head: the neck's yaw actuator holds a few N·m, so up to 250 N·m on the head
    spins it about the neck (344 rad/s measured on CPU, an upright T1 at rest; worlds past 1,000 rad/s count as
    unstable, 4.5-30% of episode ends in a GPU trial). Name the lifted link ("H2") for AGILE's behaviour."""
    target_height_m: float = 0.65
    """Root height above the terrain the target rises to."""
    start_lifting_time_s: float = 3.0
    """Episode time at which the target starts rising from 0."""
    lifting_duration_s: float = 10.0
    """Time the target takes to rise from 0 to `target_height_m`."""
    height_sensor: str | None = "height_measurement_sensor"
    """Height scanner under the root: the height is measured above the terrain it sees (None: above z=0)."""
    training_only: bool = True
    """An aid to learning, absent on the robot: students and exported policies drop every action term so marked."""
