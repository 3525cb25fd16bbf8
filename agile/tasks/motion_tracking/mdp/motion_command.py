"""Motion command (BeyondMimic `MotionCommand`): a reference motion played from a sampled frame, with the robot
placed in the reference's state at each episode start.

Each env plays the motion from its own frame (`time_steps`), one frame per env step. An episode starts at a
frame drawn by adaptive sampling: the motion is cut into one-second bins, and a bin is drawn with probability
proportional to its recent failure rate (an exponential average of the episodes that ended by failing in it) plus
a uniform share, so the policy practises the segments it fails. At that frame the robot gets the reference's root
pose, root velocity and joint state, each perturbed (`pose_range`, `velocity_range`, `joint_position_range`).
When the motion ends before the episode, the env continues from a newly drawn frame, written the same way.

The body targets the rewards compare with are anchor-relative: each tracked reference body is moved by the
yaw-and-horizontal offset between the reference anchor (torso) and the robot's anchor, keeping the reference
height, so that the body rewards judge the pose, not a drift of the whole robot.

Metrics of each episode (`CommandTerm.metrics`), means over its steps: `body_pos_error_m`, the mean over the
tracked bodies of the distance from each to its anchor-relative target (the body rewards' targets), and
`joint_pos_error_rad`, the mean over all joints of |q - q_ref|.
"""

from __future__ import annotations

from dataclasses import field

import torch

from agile.motion import check_names_match, load_motion
from agile.rl_env.managers import CommandTerm
from agile.rl_env.managers.command_manager import ReferencePose
from agile.utils.config import check_range, configclass
from agile.utils.math import quat_conjugate, quat_from_euler_xyz, quat_mul, quat_rotate, yaw_from_quat

AXES = ("x", "y", "z", "roll", "pitch", "yaw")


def yaw_quat(q_xyzw: torch.Tensor) -> torch.Tensor:
    """The heading part of orientations: a rotation about world z by their yaw."""
    yaw = yaw_from_quat(q_xyzw)
    zero = torch.zeros_like(yaw)
    return quat_from_euler_xyz(zero, zero, yaw)


def _axis_bounds(ranges: dict[str, tuple[float, float]], name: str, device) -> tuple[torch.Tensor, torch.Tensor]:
    unknown = sorted(set(ranges) - set(AXES))
    if unknown:
        raise ValueError(f"{name}: unknown axes {unknown}; axes are {list(AXES)}")
    for axis, low_high in ranges.items():
        check_range(f"{name}.{axis}", low_high)
    low = torch.tensor([ranges.get(a, (0.0, 0.0))[0] for a in AXES], dtype=torch.float32, device=device)
    high = torch.tensor([ranges.get(a, (0.0, 0.0))[1] for a in AXES], dtype=torch.float32, device=device)
    return low, high


class MotionCommand(CommandTerm):
    """Command (N, 2J): the reference joint positions [rad] and velocities [rad/s] at each env's frame."""

    def __init__(self, cfg: MotionCommandCfg, env):
        super().__init__(cfg, env)
        device = env.device
        if not 0.0 < cfg.adaptive_alpha <= 1.0:
            raise ValueError(f"adaptive_alpha is the weight of the newest failures, within (0, 1], "
                             f"got {cfg.adaptive_alpha}")
        if cfg.start_frame is not None and cfg.start_frame < 0:
            raise ValueError(f"start_frame must be a frame index >= 0 (or None: adaptive sampling), got {cfg.start_frame}")
        if cfg.adaptive_uniform_ratio < 0.0 or cfg.adaptive_kernel_size < 1:
            raise ValueError("adaptive_uniform_ratio must be >= 0 and adaptive_kernel_size >= 1")
        check_range("joint_position_range", cfg.joint_position_range)
        self.pose_low, self.pose_high = _axis_bounds(cfg.pose_range, "pose_range", device)
        self.velocity_low, self.velocity_high = _axis_bounds(cfg.velocity_range, "velocity_range", device)

        self.robot = robot = env.scene[cfg.asset_name]
        where = f"commands: motion file '{cfg.motion_file}'"
        motion = load_motion(cfg.motion_file)
        check_names_match(motion.joint_names, robot.joint_names, "joint", where)
        body_ids, self.body_names = robot.find_bodies(cfg.body_names, preserve_order=True)
        self.body_ids = torch.tensor(body_ids, dtype=torch.long, device=device)
        """The tracked bodies' indices in the robot, on the device: a captured step may not copy a list from the
        host."""
        root_body = robot.body_names[0]
        check_names_match(motion.body_names, [root_body, *self.body_names], "body", where)
        if cfg.anchor_body_name not in self.body_names:
            raise ValueError(f"anchor_body_name '{cfg.anchor_body_name}' is not a tracked body: {self.body_names}")
        if cfg.start_frame is not None and cfg.start_frame >= motion.num_frames:
            raise ValueError(f"{where}: start_frame {cfg.start_frame}; the motion has {motion.num_frames} frames")
        if abs(motion.fps * env.step_dt - 1.0) > 1e-4:
            raise ValueError(f"{where}: {motion.fps} fps; the task's control rate is {1.0 / env.step_dt:g} Hz "
                             f"(convert the motion with --output_fps {1.0 / env.step_dt:g})")

        def tensor(array):
            return torch.as_tensor(array, dtype=torch.float32, device=device)

        joints = [motion.joint_names.index(n) for n in robot.joint_names]
        bodies = [motion.body_names.index(n) for n in self.body_names]
        root = motion.body_names.index(root_body)
        self.num_frames = motion.num_frames
        self.motion_joint_pos = tensor(motion.joint_pos[:, joints])
        self.motion_joint_vel = tensor(motion.joint_vel[:, joints])
        self.motion_body_pos = tensor(motion.body_pos_w[:, bodies])  # relative to the env origin
        self.motion_body_quat = tensor(motion.body_quat_w[:, bodies])
        self.motion_body_lin_vel = tensor(motion.body_lin_vel_w[:, bodies])
        self.motion_body_ang_vel = tensor(motion.body_ang_vel_w[:, bodies])
        self.motion_root_pose = tensor(motion.body_pos_w[:, root]), tensor(motion.body_quat_w[:, root])
        self.motion_root_vel = tensor(motion.body_lin_vel_w[:, root]), tensor(motion.body_ang_vel_w[:, root])
        self.anchor_index = self.body_names.index(cfg.anchor_body_name)
        """The anchor's index among the tracked bodies."""
        self.anchor_body_id = body_ids[self.anchor_index]
        """The anchor's index in the robot (a Python int: indexing with it copies nothing)."""

        n, b = env.num_envs, len(self.body_ids)
        self.time_steps = torch.zeros(n, dtype=torch.long, device=device)
        """(N,) each env's frame of the motion."""
        self.body_pos_relative_w = torch.zeros(n, b, 3, device=device)
        self.body_quat_relative_w = torch.zeros(n, b, 4, device=device)
        self.body_quat_relative_w[..., 3] = 1.0
        # -- adaptive sampling: one bin per second of motion
        self.bin_count = int(self.num_frames * env.step_dt) + 1
        self.bin_failed_count = torch.zeros(self.bin_count, device=device)
        """Exponential average over env steps of the failures per bin."""
        self.current_bin_failed = torch.zeros(self.bin_count, device=device)
        """Failures per bin since the last env step."""
        kernel = torch.tensor([cfg.adaptive_lambda ** i for i in range(cfg.adaptive_kernel_size)], device=device)
        self.kernel = (kernel / kernel.sum()).view(1, 1, -1)
        self._body_pos_error = self._episode_mean("body_pos_error_m")
        self._joint_pos_error = self._episode_mean("joint_pos_error_rad")

    # -- the command and the reference at each env's frame ------------------------------------------------

    @property
    def command(self) -> torch.Tensor:
        return torch.cat([self.joint_pos, self.joint_vel], dim=1)

    @property
    def joint_pos(self) -> torch.Tensor:
        return self.motion_joint_pos[self.time_steps]

    @property
    def joint_vel(self) -> torch.Tensor:
        return self.motion_joint_vel[self.time_steps]

    @property
    def body_pos_w(self) -> torch.Tensor:
        return self.motion_body_pos[self.time_steps] + self.env.env_origins.unsqueeze(1)

    @property
    def body_quat_w(self) -> torch.Tensor:
        return self.motion_body_quat[self.time_steps]

    @property
    def body_lin_vel_w(self) -> torch.Tensor:
        return self.motion_body_lin_vel[self.time_steps]

    @property
    def body_ang_vel_w(self) -> torch.Tensor:
        return self.motion_body_ang_vel[self.time_steps]

    @property
    def anchor_pos_w(self) -> torch.Tensor:
        return self.motion_body_pos[self.time_steps, self.anchor_index] + self.env.env_origins

    @property
    def anchor_quat_w(self) -> torch.Tensor:
        return self.motion_body_quat[self.time_steps, self.anchor_index]

    def reference_pose(self) -> ReferencePose:
        """The reference root pose and joint angles at each env's frame (the frame the policy is now asked to
        reach: one control step ahead of the state the rewards last judged)."""
        root_pos_w = self.motion_root_pose[0][self.time_steps] + self.env.env_origins
        root_pose_w = torch.cat([root_pos_w, self.motion_root_pose[1][self.time_steps]], dim=1)
        return ReferencePose(self.cfg.asset_name, root_pose_w, self.joint_pos)

    # -- the robot's tracked bodies ------------------------------------------------------------------------

    @property
    def robot_body_pos_w(self) -> torch.Tensor:
        return self.robot.body_pose_w[:, self.body_ids, :3]

    @property
    def robot_body_quat_w(self) -> torch.Tensor:
        return self.robot.body_pose_w[:, self.body_ids, 3:7]

    @property
    def robot_body_lin_vel_w(self) -> torch.Tensor:
        return self.robot.body_vel_w[:, self.body_ids, :3]

    @property
    def robot_body_ang_vel_w(self) -> torch.Tensor:
        return self.robot.body_vel_w[:, self.body_ids, 3:6]

    @property
    def robot_anchor_pos_w(self) -> torch.Tensor:
        return self.robot.body_pose_w[:, self.anchor_body_id, :3]

    @property
    def robot_anchor_quat_w(self) -> torch.Tensor:
        return self.robot.body_pose_w[:, self.anchor_body_id, 3:7]

    # -- adaptive sampling ----------------------------------------------------------------------------------

    def sampling_probabilities(self) -> torch.Tensor:
        """(bins,) probability of starting in each bin: failure average plus a uniform share, smoothed towards
        the bins before a failure by the kernel (weights adaptive_lambda^k for the k-th bin ahead)."""
        weights = self.bin_failed_count + self.cfg.adaptive_uniform_ratio / self.bin_count
        padded = torch.nn.functional.pad(weights.view(1, 1, -1), (0, self.kernel.shape[-1] - 1), mode="replicate")
        smoothed = torch.nn.functional.conv1d(padded, self.kernel).view(-1)
        return smoothed / smoothed.sum()

    def _frame_bins(self) -> torch.Tensor:
        return (self.time_steps * self.bin_count // self.num_frames).clamp(0, self.bin_count - 1)

    def _resample(self, env_mask: torch.Tensor) -> None:
        """New start frames for the masked envs (recording where the failed ones failed), and the robot there."""
        failed = env_mask & self.env.termination_manager.terminated
        self.current_bin_failed.scatter_add_(0, self._frame_bins(), failed.float())
        n = self.env.num_envs
        if self.cfg.start_frame is None:
            bins = torch.multinomial(self.sampling_probabilities(), n, replacement=True)
            start = ((bins + torch.rand(n, device=self.env.device)) / self.bin_count * (self.num_frames - 1)).long()
        else:
            start = torch.full((n,), self.cfg.start_frame, dtype=torch.long, device=self.env.device)
        self.time_steps.copy_(torch.where(env_mask, start, self.time_steps))
        self._write_reference_state(env_mask)

    def _write_reference_state(self, env_mask: torch.Tensor) -> None:
        """Put the masked robots in the reference state at their frame, perturbed by the configured ranges."""
        n, device, robot = self.env.num_envs, self.env.device, self.robot
        pose_delta = torch.rand(n, 6, device=device) * (self.pose_high - self.pose_low) + self.pose_low
        vel_delta = torch.rand(n, 6, device=device) * (self.velocity_high - self.velocity_low) + self.velocity_low
        root_pos = self.motion_root_pose[0][self.time_steps] + self.env.env_origins + pose_delta[:, :3]
        root_quat = quat_mul(quat_from_euler_xyz(pose_delta[:, 3], pose_delta[:, 4], pose_delta[:, 5]),
                             self.motion_root_pose[1][self.time_steps])
        root_vel = torch.cat([self.motion_root_vel[0][self.time_steps], self.motion_root_vel[1][self.time_steps]], 1)
        low, high = self.cfg.joint_position_range
        joint_pos = self.joint_pos + torch.rand_like(self.joint_pos) * (high - low) + low
        limits = robot.soft_joint_pos_limits
        joint_pos = torch.clamp(joint_pos, limits[..., 0], limits[..., 1])
        robot.write_joint_state(joint_pos, self.joint_vel, env_mask)
        robot.write_root_state(torch.cat([root_pos, root_quat], 1), root_vel + vel_delta, env_mask)
        self.env.sim.forward(env_mask)
        robot.update()

    # -- per step -------------------------------------------------------------------------------------------

    def update_metrics(self) -> None:
        """The tracking errors of the state the rewards judge, against the targets they use."""
        body_error_m = torch.linalg.norm(self.robot_body_pos_w - self.body_pos_relative_w, dim=-1)
        self._body_pos_error.add(body_error_m.mean(dim=-1))
        self._joint_pos_error.add((self.robot.joint_pos - self.joint_pos).abs().mean(dim=-1))

    def compute(self, dt: float) -> None:
        """Advance every env one frame; an env past the motion's end starts again from a sampled frame."""
        self.time_steps += 1
        self._resample(self.time_steps >= self.num_frames)
        alpha = self.cfg.adaptive_alpha
        self.bin_failed_count.mul_(1.0 - alpha).add_(alpha * self.current_bin_failed)
        self.current_bin_failed.zero_()
        super().compute(dt)

    def _update_command(self) -> None:
        """The anchor-relative body targets: the reference bodies turned about the reference anchor by the yaw
        between the two anchors and moved to the robot anchor's horizontal position (reference height)."""
        b = len(self.body_ids)
        anchor_pos_w, anchor_quat_w = self.anchor_pos_w, self.anchor_quat_w
        delta_pos_w = self.robot_anchor_pos_w.clone()
        delta_pos_w[:, 2] = anchor_pos_w[:, 2]
        delta_quat_w = yaw_quat(quat_mul(self.robot_anchor_quat_w, quat_conjugate(anchor_quat_w)))
        delta_quat_w = delta_quat_w.unsqueeze(1).expand(-1, b, -1)
        self.body_quat_relative_w.copy_(quat_mul(delta_quat_w, self.body_quat_w))
        offsets = self.body_pos_w - anchor_pos_w.unsqueeze(1)
        self.body_pos_relative_w.copy_(delta_pos_w.unsqueeze(1) + quat_rotate(delta_quat_w, offsets))


@configclass
class MotionCommandCfg:
    class_type: type = MotionCommand
    asset_name: str = "robot"
    motion_file: str = ""
    """A motion file (`agile.motion.motion_file`): a path, or the name of a shipped motion."""
    anchor_body_name: str = "torso_link"
    body_names: list[str] = field(default_factory=list)
    """The tracked bodies (exact names), in the order of the body terms."""
    resampling_time_range_s: tuple[float, float] = (1.0e9, 1.0e9)
    """Never on a timer: new start frames are drawn at episode starts and when the motion ends."""
    pose_range: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Uniform offsets of the root pose at a start (x, y, z [m]; roll, pitch, yaw [rad])."""
    velocity_range: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Uniform offsets of the root velocity at a start (x, y, z [m/s]; roll, pitch, yaw [rad/s]; world frame)."""
    joint_position_range: tuple[float, float] = (0.0, 0.0)
    """Uniform offset of every joint angle at a start [rad], then clamped to the soft limits."""
    start_frame: int | None = None
    """None: episodes start at frames drawn by adaptive sampling (training). A frame index: every episode starts
    there, for evaluating or watching the whole motion (`start_frame=0` with an episode as long as the motion)."""
    adaptive_kernel_size: int = 1
    adaptive_lambda: float = 0.8
    adaptive_uniform_ratio: float = 0.1
    """Uniform share added to the failure weights (spread over the bins)."""
    adaptive_alpha: float = 0.001
    """Weight of each env step's failures in the per-bin failure average."""
