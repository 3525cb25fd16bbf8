"""Random joint-position targets for joints the policy does not control (AGILE `RandomActionCfg`).

Training-only: the term has action dimension 0, so it is not part of the policy's action vector and the
policy export leaves it out. Every `sample_range_s` a new target, uniform within the joint limits, is reached
through a trapezoidal velocity profile (accelerate, cruise, decelerate), from rest to rest.

Differences from AGILE, so that the commanded target never jumps in position or velocity: a motion always
runs to its end (a new target waits for the current one to be reached, where AGILE restarts mid-motion), and
the profile is evaluated in closed form per joint with that joint's own acceleration.
"""

from __future__ import annotations

from dataclasses import field

import torch
import warp as wp

from agile.rl_env.managers import ActionTerm, ActionTermCfg
from agile.sim.names import resolve_names
from agile.utils.config import configclass

TIME_SCALING_METHODS = ("max_time",)


@configclass
class TrapezoidalVelocityProfileCfg:
    acceleration_range: tuple[float, float] = (0.5, 2.0)
    """Acceleration and deceleration [rad/s²], drawn per joint for every motion."""
    max_velocity_range: tuple[float, float] = (0.5, 2.0)
    """Cruise velocity bound [rad/s], drawn per joint for every motion; also bounded by the joint's limit."""
    min_cruise_ratio: float = 0.1
    """Minimum fraction of a motion's duration spent cruising (0: triangular profiles allowed)."""
    synchronize_joints: bool = True
    """All joints of an env start and arrive together."""
    time_scaling_method: str = "max_time"
    """How synchronized joints share a duration: 'max_time' (the slowest joint's minimum time)."""


@wp.struct
class Motions:
    """The profile's state, (num_envs, num_joints) but for the per-env clock: Warp views of TrapezoidalProfile's
    tensors."""

    start: wp.array2d(dtype=float)
    distance: wp.array2d(dtype=float)  # signed [rad]
    acceleration: wp.array2d(dtype=float)
    cruise_velocity: wp.array2d(dtype=float)  # unsigned [rad/s]
    duration_s: wp.array2d(dtype=float)
    elapsed_s: wp.array(dtype=float)


@wp.struct
class PlanInputs:
    """What a plan reads besides where and whereto: uniform [0, 1) draws per joint, the joints' velocity limits, the
    profile's settings (spans and ratio factors computed in double, as Python scalars are in torch)."""

    acceleration_draw: wp.array2d(dtype=float)
    velocity_draw: wp.array2d(dtype=float)
    velocity_limit: wp.array2d(dtype=float)
    acceleration_low: float
    acceleration_span: float
    velocity_low: float
    velocity_span: float
    one_minus_ratio: float
    one_plus_ratio: float
    synchronize: int


@wp.func
def _plan_env(env: int, plan_from: wp.array2d(dtype=float), target: wp.array2d(dtype=float), p: PlanInputs,
              m: Motions):
    """A rest-to-rest motion of every joint of `env` from `plan_from` to `target` (see TrapezoidalProfile). Written
    operation for operation as torch evaluates the same expressions, so that CPU rollouts stay close to the
    recordings: they agree but for the rounding of sqrt, which Warp rounds correctly and torch's CPU kernel not."""
    num_joints = m.start.shape[1]
    longest_s = float(0.0)
    for j in range(num_joints):  # each joint's minimum time, kept in duration_s until the shared one is known
        d = wp.abs(target[env, j] - plan_from[env, j])
        a = p.acceleration_draw[env, j] * p.acceleration_span + p.acceleration_low
        v_bound = wp.min(p.velocity_draw[env, j] * p.velocity_span + p.velocity_low, p.velocity_limit[env, j])
        v_best = wp.min(v_bound, wp.sqrt(a * d * p.one_minus_ratio / p.one_plus_ratio))
        min_time_s = float(0.0)
        if v_best > 0.0:
            min_time_s = d / v_best + v_best / a
        m.duration_s[env, j] = min_time_s
        m.acceleration[env, j] = a
        m.distance[env, j] = target[env, j] - plan_from[env, j]
        longest_s = wp.max(longest_s, min_time_s)
    for j in range(num_joints):
        T = m.duration_s[env, j]
        if p.synchronize != 0:
            T = longest_s
        a = m.acceleration[env, j]
        d = wp.abs(m.distance[env, j])
        m.cruise_velocity[env, j] = 0.5 * (a * T - wp.sqrt(wp.max(a * a * T * T - 4.0 * a * d, 0.0)))
        m.start[env, j] = plan_from[env, j]
        m.duration_s[env, j] = T
    m.elapsed_s[env] = 0.0


@wp.func
def _position(env: int, j: int, m: Motions) -> float:
    a, v, T = m.acceleration[env, j], m.cruise_velocity[env, j], m.duration_s[env, j]
    signed = m.distance[env, j]
    d = wp.abs(signed)
    t = wp.min(m.elapsed_s[env], T)
    t_acc = v / a
    travelled = d - 0.5 * a * ((T - t) * (T - t))  # decelerating
    if t < t_acc:
        travelled = 0.5 * a * t * t  # accelerating
    elif t <= T - t_acc:
        travelled = v * t - 0.5 * v * v / a  # cruising
    direction = float(0.0)
    if signed > 0.0:
        direction = 1.0
    elif signed < 0.0:
        direction = -1.0
    return m.start[env, j] + direction * travelled


@wp.kernel(enable_backward=False)
def _plan(plan_from: wp.array2d(dtype=float), target: wp.array2d(dtype=float), mask: wp.array(dtype=wp.bool),
          p: PlanInputs, m: Motions):
    env = wp.tid()
    if mask[env]:
        _plan_env(env, plan_from, target, p, m)


@wp.kernel(enable_backward=False)
def _positions(m: Motions, positions: wp.array2d(dtype=float)):
    env, j = wp.tid()
    positions[env, j] = _position(env, j, m)


@wp.kernel(enable_backward=False)
def _random_motion_step(target_draw: wp.array2d(dtype=float), interval_draw: wp.array(dtype=float),
                        walking: wp.array(dtype=wp.bool), offset: wp.array2d(dtype=float),
                        position_low: wp.array2d(dtype=float), position_high: wp.array2d(dtype=float),
                        interval_low_s: float, interval_span_s: float, step_dt_s: float, p: PlanInputs, m: Motions,
                        time_left_s: wp.array(dtype=float), target: wp.array2d(dtype=float),
                        positions: wp.array2d(dtype=float)):
    """One env step of RandomPositionAction for one env: a new motion from where the joints are once the interval
    is over and the running motion done, then the profile advanced and evaluated into `positions`."""
    env = wp.tid()
    num_joints = m.start.shape[1]
    time_left = time_left_s[env] - step_dt_s
    done = bool(True)
    for j in range(num_joints):
        if m.elapsed_s[env] < m.duration_s[env, j]:
            done = False
    if time_left <= 0.0 and done:
        for j in range(num_joints):
            target[env, j] = target_draw[env, j] * (position_high[env, j] - position_low[env, j]) + position_low[env, j]
            if walking[env]:
                target[env, j] = offset[env, j]
        _plan_env(env, positions, target, p, m)
        time_left = interval_draw[env] * interval_span_s + interval_low_s
    time_left_s[env] = time_left
    m.elapsed_s[env] = m.elapsed_s[env] + step_dt_s
    for j in range(num_joints):
        positions[env, j] = _position(env, j, m)


class TrapezoidalProfile:
    """Rest-to-rest point-to-point motions of (num_envs, num_joints) joints, planned and evaluated in closed form
    (float32 Warp kernels: one launch plans every masked env, one evaluates every joint).

    For a distance d, acceleration a and cruise velocity v, a motion of duration T satisfies d = v·T − v²/a
    and spends t_a = v/a accelerating and decelerating. A joint's minimum time uses the largest v allowed by
    its velocity bound and by the minimum cruise ratio (2·t_a <= (1 − r)·T  <=>  v <= √(a·d·(1 − r)/(1 + r)));
    a longer, synchronized T then takes the smaller root v = (a·T − √(a²T² − 4·a·d))/2, which stays below
    that bound, so velocity and acceleration limits hold for every joint.
    """

    def __init__(self, cfg: TrapezoidalVelocityProfileCfg, velocity_limit_rad_s: torch.Tensor):
        if cfg.time_scaling_method not in TIME_SCALING_METHODS:
            raise ValueError(f"time_scaling_method '{cfg.time_scaling_method}' not in {TIME_SCALING_METHODS}")
        if cfg.acceleration_range[0] <= 0.0 or cfg.max_velocity_range[0] <= 0.0:
            raise ValueError("acceleration_range and max_velocity_range must be positive")
        if not 0.0 <= cfg.min_cruise_ratio < 1.0:
            raise ValueError(f"min_cruise_ratio must be in [0, 1), got {cfg.min_cruise_ratio}")
        self.cfg = cfg
        self.velocity_limit_rad_s = velocity_limit_rad_s.float().contiguous()
        zeros = torch.zeros_like(self.velocity_limit_rad_s)
        num_envs, num_joints = zeros.shape
        self.start = zeros.clone()
        self.distance = zeros.clone()  # signed [rad]
        self.acceleration = torch.ones_like(zeros)
        self.cruise_velocity = zeros.clone()  # unsigned [rad/s]
        self.duration_s = zeros.clone()
        self.elapsed_s = zeros[:, 0].clone()
        self.acceleration_draw = zeros.clone()
        self.velocity_draw = zeros.clone()
        """Uniform [0, 1) draws of a plan, per joint, by torch's generator (seeds and CUDA graphs as elsewhere)."""
        self.wp_device = wp.get_device(str(zeros.device))  # (initialises Warp if nothing has yet)
        (a_low, a_high), (v_low, v_high), r = cfg.acceleration_range, cfg.max_velocity_range, cfg.min_cruise_ratio
        # Warp views of the same memory, made once
        self.plan_inputs = PlanInputs()
        self.plan_inputs.acceleration_draw = wp.from_torch(self.acceleration_draw)
        self.plan_inputs.velocity_draw = wp.from_torch(self.velocity_draw)
        self.plan_inputs.velocity_limit = wp.from_torch(self.velocity_limit_rad_s)
        self.plan_inputs.acceleration_low, self.plan_inputs.acceleration_span = float(a_low), float(a_high - a_low)
        self.plan_inputs.velocity_low, self.plan_inputs.velocity_span = float(v_low), float(v_high - v_low)
        self.plan_inputs.one_minus_ratio, self.plan_inputs.one_plus_ratio = float(1.0 - r), float(1.0 + r)
        self.plan_inputs.synchronize = int(cfg.synchronize_joints)
        self.motions = Motions()
        for name in ("start", "distance", "acceleration", "cruise_velocity", "duration_s", "elapsed_s"):
            setattr(self.motions, name, wp.from_torch(getattr(self, name)))

    @property
    def done(self) -> torch.Tensor:
        """(num_envs,) True where every joint has arrived."""
        return (self.elapsed_s.unsqueeze(-1) >= self.duration_s).all(dim=-1)

    def plan(self, start: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> None:
        """Start new motions from rest at `start` to `target` (num_envs, num_joints) where mask (num_envs,) is True."""
        self.draw()
        wp.launch(_plan, dim=self.elapsed_s.shape[0], device=self.wp_device,
                  inputs=[wp.from_torch(start.float().contiguous()), wp.from_torch(target.float().contiguous()),
                          wp.from_torch(mask.contiguous(), dtype=wp.bool), self.plan_inputs, self.motions])

    def draw(self) -> None:
        """New draws for the next plan: every joint's acceleration, then its velocity bound."""
        self.acceleration_draw.uniform_()
        self.velocity_draw.uniform_()

    def advance(self, dt_s: float) -> None:
        self.elapsed_s += dt_s

    def position(self) -> torch.Tensor:
        """(num_envs, num_joints) positions at the elapsed time."""
        positions = torch.empty_like(self.start)
        wp.launch(_positions, dim=tuple(self.start.shape), inputs=[self.motions], outputs=[wp.from_torch(positions)],
                  device=self.wp_device)
        return positions


class RandomPositionAction(ActionTerm):
    """Random position targets through a trapezoidal profile on joints outside the policy (training only)."""

    def __init__(self, cfg: RandomActionCfg, env):
        super().__init__(cfg, env)
        robot = env.scene[cfg.asset_name]
        self.robot = robot
        if (cfg.joint_names is None) == (cfg.joint_names_exclude is None):
            raise ValueError("set exactly one of joint_names and joint_names_exclude")
        if cfg.joint_names is not None:
            joint_ids, self.joint_names = robot.find_joints(cfg.joint_names)
        else:
            excluded = robot.find_joints(cfg.joint_names_exclude)[0] if cfg.joint_names_exclude else []
            joint_ids = [i for i in range(robot.num_joints) if i not in excluded]
            self.joint_names = [robot.joint_names[i] for i in joint_ids]
        if not joint_ids:
            raise ValueError("no joints left for random actions")
        self.joint_ids = torch.tensor(joint_ids, dtype=torch.long, device=env.device)
        self.offset = robot.default_joint_pos[:, self.joint_ids].clone()
        self.pos_limits = robot.joint_pos_limits[:, self.joint_ids].clone()  # (N, J, 2) [rad]
        for expr, (low, high) in cfg.joint_pos_limits.items():
            ids, _ = resolve_names(expr, self.joint_names)
            self.pos_limits[:, ids, 0] = float(low)
            self.pos_limits[:, ids, 1] = float(high)
        self.profile = TrapezoidalProfile(cfg.velocity_profile_cfg, robot.joint_vel_limit[:, self.joint_ids].clone())
        self.processed_actions = self.offset.clone()
        """Commanded position targets [rad] of the term's joints."""
        self.time_left_s = torch.zeros(env.num_envs, device=env.device)
        self.walking = torch.zeros(env.num_envs, dtype=torch.bool, device=env.device)
        """Where the velocity command is not zero (`no_random_when_walking`): targets are the defaults."""
        self.target_draw = torch.zeros_like(self.offset)
        self.interval_draw = torch.zeros_like(self.time_left_s)
        """Uniform [0, 1) draws of a step: a target per joint, an interval per env."""
        low, high = self.pos_limits[..., 0].contiguous(), self.pos_limits[..., 1].contiguous()
        interval_low_s, interval_high_s = cfg.sample_range_s
        self._target = torch.zeros_like(self.offset)
        profile = self.profile
        self._step_args = [wp.from_torch(self.target_draw), wp.from_torch(self.interval_draw),
                           wp.from_torch(self.walking, dtype=wp.bool), wp.from_torch(self.offset), wp.from_torch(low),
                           wp.from_torch(high), float(interval_low_s), float(interval_high_s - interval_low_s),
                           float(env.step_dt), profile.plan_inputs, profile.motions, wp.from_torch(self.time_left_s),
                           wp.from_torch(self._target), wp.from_torch(self.processed_actions)]
        self.time_left_s.copy_(self._sample_interval())
        self.profile.plan(self.offset, self.offset, torch.ones(env.num_envs, dtype=torch.bool, device=env.device))

    def _sample_interval(self) -> torch.Tensor:
        low, high = self.cfg.sample_range_s
        return self.interval_draw.uniform_() * (high - low) + low

    @property
    def action_dim(self) -> int:
        return 0

    def process_actions(self, actions: torch.Tensor) -> None:
        """One Warp kernel after the draws: the interval counted down; where it is over and the running motion done,
        a new target (uniform within the limits, or the defaults while walking) and its motion from where the joints
        are; the profile advanced one env step and evaluated."""
        if self.cfg.no_random_when_walking:
            # AGILE: an env told to walk moves these joints back to their defaults (after the running motion)
            command = self.env.command_manager.get_command(self.cfg.command_name)
            torch.any(command[:, :3] != 0.0, dim=1, out=self.walking)
        self.target_draw.uniform_()
        self.profile.draw()
        self.interval_draw.uniform_()
        wp.launch(_random_motion_step, dim=self.env.num_envs, inputs=self._step_args, device=self.profile.wp_device)

    def apply_actions(self) -> None:
        self.robot.joint_pos_target[:, self.joint_ids] = self.processed_actions

    def reset(self, env_mask: torch.Tensor) -> None:
        self.processed_actions.copy_(torch.where(env_mask.unsqueeze(-1), self.offset, self.processed_actions))
        self.profile.plan(self.offset, self.offset, env_mask)  # at rest at the defaults
        self.time_left_s.copy_(torch.where(env_mask, self._sample_interval(), self.time_left_s))


@configclass
class RandomActionCfg(ActionTermCfg):
    """AGILE `RandomActionCfg` with a trapezoidal velocity profile. Select joints by `joint_names` or by
    `joint_names_exclude` (every joint not matched), not both."""

    class_type: type = RandomPositionAction
    joint_names: list[str] | None = None
    joint_names_exclude: list[str] | None = None
    sample_range_s: tuple[float, float] = (0.1, 2.5)
    """Time between new targets [s], drawn per env (a running motion finishes first)."""
    velocity_profile_cfg: TrapezoidalVelocityProfileCfg = TrapezoidalVelocityProfileCfg()
    joint_pos_limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    """{joint regex: (low, high)} [rad] replacing the model's limits for target sampling."""
    no_random_when_walking: bool = False
    """Targets are the default positions while the velocity command `command_name` is not zero."""
    command_name: str = "base_velocity"
