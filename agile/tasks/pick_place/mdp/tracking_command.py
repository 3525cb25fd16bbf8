"""TrackingCommand (AGILE `TrackingCommandCfg`): a pick-and-place reference from trajectory files.

Each env follows one trajectory (drawn at its episode start among the configured files), resampled at the
control rate, one frame per env step from a random start frame; past its end it holds the last frame. At the
start the tracked joints are put at the reference (AGILE's `reset_robot_to_trajectory` event). The reference
gives the tracked joints' targets, the anchor body's pose and the object's pose, the phase and the progress.

Metrics of each episode (`CommandTerm.metrics`): `joint_pos_error_rad`, the mean over its steps and the tracked
joints of |q - q_ref|; with an object (`object_name`), `object_lifted` (1 if the object was ever `lift_margin_m`
above its height at the episode start), `object_goal_distance_m` (at the end, from the object to the
trajectory's last object position) and `object_at_goal` (1 if that is within `goal_tolerance_m`).
"""

from __future__ import annotations

from dataclasses import field

import numpy as np
import torch

from agile.motion.trajectory_file import IN_HAND_PHASES, PHASES, load_trajectory, resample
from agile.rl_env.managers.command_manager import CommandTerm
from agile.utils.config import check_range, configclass


class TrackingCommand(CommandTerm):
    """Command (N, J): the tracked joints' reference positions [rad] at each env's frame."""

    def __init__(self, cfg: TrackingCommandCfg, env):
        super().__init__(cfg, env)
        device = env.device
        if not cfg.trajectory_files:
            raise ValueError("trajectory_files: give at least one trajectory file (a path or a shipped name)")
        check_range("start_step_range", cfg.start_step_range, minimum=0)
        trajectories = [resample(load_trajectory(f), env.step_dt) for f in cfg.trajectory_files]
        first = trajectories[0]
        for name, trajectory in zip(cfg.trajectory_files, trajectories, strict=True):
            if trajectory.joint_names != first.joint_names or trajectory.anchor_body != first.anchor_body:
                raise ValueError(f"trajectory_files: '{name}' tracks {trajectory.joint_names} on "
                                 f"'{trajectory.anchor_body}', '{cfg.trajectory_files[0]}' tracks "
                                 f"{first.joint_names} on '{first.anchor_body}'; all must track the same")
        self.robot = robot = env.scene[cfg.asset_name]
        missing = [n for n in first.joint_names if n not in robot.joint_names]
        if missing:
            raise ValueError(f"trajectory joints {missing} are not in robot '{cfg.asset_name}'. "
                             f"Its joints: {list(robot.joint_names)}")
        self.joint_names = list(first.joint_names)
        self.joint_ids = torch.tensor([robot.joint_names.index(n) for n in self.joint_names], device=device)
        anchor_ids, _ = robot.find_bodies(first.anchor_body)
        self.anchor_body_id = anchor_ids[0]

        # every trajectory padded to the longest with its last frame: (K, T, ...)
        self.num_frames = torch.tensor([len(t.time_s) for t in trajectories], device=device)
        length = max(len(t.time_s) for t in trajectories)

        def stacked(key: str, dtype=torch.float32) -> torch.Tensor:
            arrays = [getattr(t, key) for t in trajectories]
            padded = [np.concatenate([a, np.repeat(a[-1:], length - len(a), axis=0)]) for a in arrays]
            return torch.as_tensor(np.stack(padded), dtype=dtype, device=device)

        self.ref_joint_pos = stacked("joint_pos")
        self.ref_object_pos = stacked("object_pos_m") + torch.tensor(cfg.pos_offset_m, device=device)
        self.ref_object_quat = stacked("object_quat_xyzw")
        self.ref_anchor_pos = stacked("anchor_pos_m")
        self.ref_anchor_quat = stacked("anchor_quat_xyzw")
        self.ref_phase = stacked("phase", torch.long)
        in_hand = torch.tensor([PHASES.index(p) for p in IN_HAND_PHASES], device=device)
        self.ref_in_hand = torch.isin(self.ref_phase, in_hand)
        # the first frame after the hand let go: where the hand-object reward starts to decay
        after_hold = ~self.ref_in_hand & (torch.cumsum(self.ref_in_hand.long(), dim=1) > 0)
        self.release_frame = torch.where(after_hold.any(dim=1), after_hold.float().argmax(dim=1),
                                         torch.full_like(self.num_frames, length))

        n = env.num_envs
        self.trajectory_ids = torch.zeros(n, dtype=torch.long, device=device)
        """(N,) each env's trajectory (index into trajectory_files)."""
        self.time_steps = torch.zeros(n, dtype=torch.long, device=device)
        """(N,) each env's frame of its trajectory."""
        self._command = torch.zeros(n, len(self.joint_names), device=device)

        self._joint_pos_error = self._episode_mean("joint_pos_error_rad")
        self.object = None
        if cfg.object_name is not None:
            if cfg.object_name not in env.scene:
                raise ValueError(f"object_name '{cfg.object_name}' is not in the scene {sorted(env.scene.keys())}; "
                                 "None measures no object")
            if cfg.lift_margin_m < 0.0 or cfg.goal_tolerance_m <= 0.0:
                raise ValueError(f"lift_margin_m must be >= 0 and goal_tolerance_m > 0 [m], got "
                                 f"{cfg.lift_margin_m} and {cfg.goal_tolerance_m}")
            self.object = env.scene[cfg.object_name]
            self.object_start_height_m = torch.zeros(n, device=device)
            """(N,) the object's height at the episode start, world frame [m]."""
            for name in ("object_lifted", "object_goal_distance_m", "object_at_goal"):
                self.metrics[name] = torch.zeros(n, device=device)

    # -- the reference at each env's frame ---------------------------------------------------------------

    @property
    def command(self) -> torch.Tensor:
        return self._command

    def _at_frame(self, values: torch.Tensor) -> torch.Tensor:
        return values[self.trajectory_ids, self.time_steps]

    @property
    def joint_pos(self) -> torch.Tensor:
        """(N, J) the tracked joints' reference positions [rad]."""
        return self._at_frame(self.ref_joint_pos)

    @property
    def final_joint_pos(self) -> torch.Tensor:
        """(N, J) the tracked joints' reference at the trajectory's last frame [rad]."""
        return self.ref_joint_pos[self.trajectory_ids, self.num_frames[self.trajectory_ids] - 1]

    @property
    def robot_joint_pos(self) -> torch.Tensor:
        return self.robot.joint_pos[:, self.joint_ids]

    @property
    def object_pos_w(self) -> torch.Tensor:
        """(N, 3) the object's reference position, world frame [m]."""
        return self._at_frame(self.ref_object_pos) + self.env.env_origins

    @property
    def goal_object_pos_w(self) -> torch.Tensor:
        """(N, 3) the object's reference position at the trajectory's last frame (where it is put down) [m]."""
        last = self.num_frames[self.trajectory_ids] - 1
        return self.ref_object_pos[self.trajectory_ids, last] + self.env.env_origins

    @property
    def object_quat_w(self) -> torch.Tensor:
        return self._at_frame(self.ref_object_quat)

    @property
    def anchor_pos_w(self) -> torch.Tensor:
        """(N, 3) the anchor body's reference position, world frame [m]."""
        return self._at_frame(self.ref_anchor_pos) + self.env.env_origins

    @property
    def anchor_quat_w(self) -> torch.Tensor:
        return self._at_frame(self.ref_anchor_quat)

    @property
    def robot_anchor_pos_w(self) -> torch.Tensor:
        return self.robot.body_pose_w[:, self.anchor_body_id, :3]

    @property
    def robot_anchor_quat_w(self) -> torch.Tensor:
        return self.robot.body_pose_w[:, self.anchor_body_id, 3:7]

    @property
    def phase(self) -> torch.Tensor:
        """(N,) the reference phase, an index into `agile.motion.trajectory_file.PHASES`."""
        return self._at_frame(self.ref_phase)

    @property
    def in_hand(self) -> torch.Tensor:
        """(N,) the reference holds the object now (phases grasp and carry)."""
        return self._at_frame(self.ref_in_hand)

    @property
    def released(self) -> torch.Tensor:
        """(N,) the reference has let the object go (at or after its first frame after the hold)."""
        return self.time_steps >= self.release_frame[self.trajectory_ids]

    @property
    def steps_since_release(self) -> torch.Tensor:
        """(N,) env steps since the reference let the object go (0 before that)."""
        return (self.time_steps - self.release_frame[self.trajectory_ids]).clamp(min=0)

    @property
    def progress(self) -> torch.Tensor:
        """(N,) the frame over the last frame, 0 at the start and 1 at the end."""
        return self.time_steps / (self.num_frames[self.trajectory_ids] - 1).clamp(min=1)

    # -- resets and steps -------------------------------------------------------------------------------

    def _resample(self, env_mask: torch.Tensor) -> None:
        """A trajectory and a start frame for the masked envs, and their tracked joints put at it."""
        n, device = self.env.num_envs, self.env.device
        trajectory = torch.randint(0, len(self.cfg.trajectory_files), (n,), device=device)
        self.trajectory_ids.copy_(torch.where(env_mask, trajectory, self.trajectory_ids))
        low, high = self.cfg.start_step_range
        start = torch.randint(int(low), int(high) + 1, (n,), device=device)
        start = torch.minimum(start, self.num_frames[self.trajectory_ids] - 1)
        self.time_steps.copy_(torch.where(env_mask, start, self.time_steps))
        if self.cfg.reset_joints_to_reference:
            joint_pos, joint_vel = self.robot.joint_pos.clone(), self.robot.joint_vel.clone()
            joint_pos[:, self.joint_ids] = self.joint_pos
            joint_vel.index_fill_(1, self.joint_ids, 0.0)  # a scalar put by index would copy it from the host
            self.robot.write_joint_state(joint_pos, joint_vel, env_mask)
            self.env.sim.forward(env_mask)
            self.robot.update()

    def episode_variants(self) -> tuple[list[str], torch.Tensor]:
        """The trajectory files (as configured) and each env's."""
        return list(self.cfg.trajectory_files), self.trajectory_ids

    def _update_command(self) -> None:
        self._command.copy_(self.joint_pos)

    def compute(self, dt: float) -> None:
        """One frame on; the last frame is held until the episode ends."""
        self.time_steps.copy_(torch.minimum(self.time_steps + 1, self.num_frames[self.trajectory_ids] - 1))
        super().compute(dt)

    # -- metrics ----------------------------------------------------------------------------------------

    def _start_episodes(self, env_mask: torch.Tensor) -> None:
        if self.object is not None:  # after the reset events: where the object starts this episode
            start_m = self.object.root_pos_w[:, 2]
            self.object_start_height_m.copy_(torch.where(env_mask, start_m, self.object_start_height_m))

    def update_metrics(self) -> None:
        self._joint_pos_error.add((self.robot_joint_pos - self.joint_pos).abs().mean(dim=-1))
        if self.object is not None:
            lifted = self.object.root_pos_w[:, 2] > self.object_start_height_m + self.cfg.lift_margin_m
            self.metrics["object_lifted"].copy_(torch.maximum(self.metrics["object_lifted"], lifted.float()))

    def finish_episodes(self, env_mask: torch.Tensor) -> None:
        if self.object is None:
            return
        distance_m = torch.linalg.norm(self.object.root_pos_w - self.goal_object_pos_w, dim=-1)
        for name, value in (("object_goal_distance_m", distance_m),
                            ("object_at_goal", (distance_m <= self.cfg.goal_tolerance_m).float())):
            self.metrics[name].copy_(torch.where(env_mask, value, self.metrics[name]))


@configclass
class TrackingCommandCfg:
    class_type: type = TrackingCommand
    asset_name: str = "robot"
    trajectory_files: list[str] = field(default_factory=list)
    """Trajectory files (`agile.motion.trajectory_file`): paths or shipped names; each env draws one per episode."""
    start_step_range: tuple[int, int] = (0, 150)
    """The first frame of an episode, drawn uniformly in this range [env steps] (AGILE: time index 0..150)."""
    reset_joints_to_reference: bool = True
    """Put the tracked joints at the reference's start frame (at rest) when an episode starts."""
    pos_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Added to the reference object positions (AGILE `pos_offset`: its retargeted data sat 6.8 cm off its table;
    the shipped trajectories are made on this task's table, so 0)."""
    resampling_time_range_s: tuple[float, float] = (1.0e9, 1.0e9)
    """Never on a timer: a trajectory and start frame are drawn at episode starts only."""
    object_name: str | None = "object"
    """The scene entity that is picked and placed, for the object metrics; None: joint metrics only."""
    lift_margin_m: float = 0.02
    """The object counts as lifted once it is this far above its height at the episode start [m]: resting on the
    table it jitters by millimetres in its contact, and a touch rocks it, which is no lift."""
    goal_tolerance_m: float = 0.05
    """The object is at the goal when it ends the episode within this distance of the trajectory's last object
    position [m]."""
