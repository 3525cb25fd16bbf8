"""Command manager: command terms (classes) resampled on timers and at resets, and the metrics they keep of each
episode (tracking errors, task success) for training logs and evaluation."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from agile.rl_env.managers.manager_base import build_class_terms
from agile.utils.config import check_range

VELOCITY_FIELDS = ("lin_vel_x_mps", "lin_vel_y_mps", "ang_vel_z_radps")
"""The first `command_fields` of a base-velocity command (base yaw frame); a base-height command adds
"base_height_m"."""


class EpisodeMean:
    """The running mean over each env's episode of a per-step value, kept on the device; `value` (N,) is the
    metric (a term's `metrics` entry)."""

    def __init__(self, num_envs: int, device):
        self.sum = torch.zeros(num_envs, device=device)
        self.steps = torch.zeros(num_envs, device=device)
        self.value = torch.zeros(num_envs, device=device)

    def add(self, step_value: torch.Tensor, counted: torch.Tensor | None = None) -> None:
        """One step's (N,) values; where `counted` (N,) bool is False, or the value is not finite (a world that
        blew up, which the env resets), the step does not count."""
        finite = torch.isfinite(step_value)
        counted = finite if counted is None else counted & finite
        self.sum.add_(torch.where(counted, step_value, 0.0))
        self.steps.add_(counted.float())
        torch.div(self.sum, self.steps.clamp(min=1.0), out=self.value)

    def start(self, env_mask: torch.Tensor) -> None:
        """New episodes of the masked envs: nothing counted yet (value 0)."""
        for buf in (self.sum, self.steps, self.value):
            buf.masked_fill_(env_mask, 0.0)


def keep_episode_end(value: torch.Tensor, last: torch.Tensor, env_mask: torch.Tensor,
                     ended_count: torch.Tensor) -> torch.Tensor:
    """The masked envs' metric `value` (N,) copied into `last` (their last episode's); returns its mean over
    them (`ended_count`, at least 1), the "Metrics/..." log entry. In place and on the device: capture-safe."""
    last.copy_(torch.where(env_mask, value, last))
    return torch.where(env_mask, value, 0.0).sum() / ended_count


@dataclass(frozen=True)
class CommandError:
    """One step of how far the robot is from what a command asks, per env: what evaluation bins by the commanded
    value (the height error by commanded height)."""

    error_name: str
    """The error's name with its unit ("height_error_m")."""
    command_name: str
    """The commanded value's name with its unit ("height_m")."""
    commanded: torch.Tensor
    """(N,) the commanded value."""
    error: torch.Tensor
    """(N,) the error."""
    measured: torch.Tensor
    """(N,) the value reached, in the commanded value's unit (what a sweep of fixed commands reports)."""
    counted: torch.Tensor
    """(N,) bool: the steps the error counts on (e.g. settled after a new command)."""
    bin_edges: tuple[float, ...]
    """Inner edges of the bins of the commanded value (from 0 up; the last bin is open)."""


@dataclass(frozen=True)
class ReferencePose:
    """The whole-body pose a command asks of one articulation, per env: what a recorder draws as a kinematic copy
    of the robot beside it (play.py --video_reference)."""

    asset_name: str
    """The articulation (scene entity) the pose is for; it must have a free root."""
    root_pose_w: torch.Tensor
    """(N, 7) root position [m] (world frame, env origin included) and orientation (x, y, z, w)."""
    joint_pos: torch.Tensor
    """(N, J) joint positions [rad], in the articulation's joint order."""


class CommandTerm:
    """Base of command terms: keeps a per-env resampling timer; subclasses define `command` and `_resample`."""

    command_fields: tuple[str, ...] = ()
    """The meaning of the command's columns where it has a layout that scripts read (eval.py measures the velocity
    errors of a command starting with VELOCITY_FIELDS); empty for other commands (a motion reference)."""

    def __init__(self, cfg, env):
        self.cfg = cfg
        self.env = env
        check_range("resampling_time_range_s", cfg.resampling_time_range_s, minimum=0.0)
        self.time_left_s = torch.zeros(env.num_envs, device=env.device)
        self.fixed_command: torch.Tensor | None = None
        """(N, D) values that replace the drawn command of every env while set (`set_fixed_command`): evaluation
        at chosen commands, a different one per env if wished."""
        self.metrics: dict[str, torch.Tensor] = {}
        """(N,) float values describing each env's episode so far, units in the name ("joint_pos_error_rad"):
        created in the term's __init__ (fixed keys and tensors: the env step may be captured as a CUDA graph),
        updated on the device by `update_metrics`, completed by `finish_episodes`, zeroed at `reset`. The
        CommandManager keeps every ended episode's values and logs their means (Metrics/<term>/<name>)."""
        self._episode_means: list[EpisodeMean] = []

    def _episode_mean(self, name: str) -> EpisodeMean:
        """A metric that is the mean over the episode's steps of a per-step value (`EpisodeMean.add`)."""
        mean = EpisodeMean(self.env.num_envs, self.env.device)
        self.metrics[name] = mean.value
        self._episode_means.append(mean)
        return mean

    def update_metrics(self) -> None:
        """Once per env step, after the physics and before any reset: the metrics of the state the rewards judge
        (an episode's last state included, its reset state not)."""

    def finish_episodes(self, env_mask: torch.Tensor) -> None:
        """For the envs whose episodes end now, before their worlds are reset (their final state is still there):
        the end-of-episode metric values (e.g. where the object ended up)."""

    @property
    def command(self) -> torch.Tensor:
        raise NotImplementedError

    def reference_pose(self) -> ReferencePose | None:
        """The whole-body pose this command asks for at each env's current frame, for terms that hold one (motion
        tracking); None for the others. Only recorders read it: it is not part of the MDP."""
        return None

    def command_error(self) -> CommandError | None:
        """This step's tracking error against the commanded value, for evaluation by command; None for commands
        without one (a velocity command's errors are measured by eval.py from its `command_fields`)."""
        return None

    def episode_variants(self) -> tuple[list[str], torch.Tensor] | None:
        """The kinds of episode this command draws (e.g. which trajectory it follows): their names and each env's
        current one, (N,) long indices into the names; None for a command without such kinds. Evaluation breaks
        its outcomes down by them."""
        return None

    def _resample(self, env_mask: torch.Tensor) -> None:
        raise NotImplementedError

    def _update_command(self) -> None:
        """Per-step update after resampling (e.g. heading control)."""

    def set_fixed_command(self, values: torch.Tensor | None) -> None:
        """Hold every env's command at `values` ((N, D) or (D,), the command's layout) from now on; None goes
        back to drawing. The term keeps its timers and internal state (e.g. a smoothed height), overwritten.
        Call it before the env's first step: on the GPU that step is captured as a CUDA graph, with or without
        the overwrite."""
        if values is None:
            self.fixed_command = None
            return
        values = torch.as_tensor(values, dtype=torch.float32, device=self.env.device)
        shape = tuple(self.command.shape)
        if values.shape not in (shape, shape[1:]):
            raise ValueError(f"fixed command of shape {tuple(values.shape)}; this command is {shape} (envs, values) "
                             f"or {shape[1:]}")
        self.fixed_command = values.expand(shape).clone()
        self.command.copy_(self.fixed_command)

    def _hold_fixed_command(self) -> None:
        if self.fixed_command is not None:
            self.command.copy_(self.fixed_command)

    def _draw_time_left(self, env_mask: torch.Tensor) -> None:
        low, high = self.cfg.resampling_time_range_s
        draw = torch.rand(self.env.num_envs, device=self.env.device) * (high - low) + low
        self.time_left_s.copy_(torch.where(env_mask, draw, self.time_left_s))

    def compute(self, dt: float) -> None:
        self.time_left_s -= dt
        mask = self.time_left_s <= 0.0
        self._draw_time_left(mask)
        self._resample(mask)
        self._update_command()
        self._hold_fixed_command()

    def _start_episodes(self, env_mask: torch.Tensor) -> None:
        """What a new episode of the masked envs needs after its first command (e.g. no smoothing ramp from the
        last episode's command)."""

    def reset(self, env_mask: torch.Tensor) -> dict:
        for value in self.metrics.values():
            value.masked_fill_(env_mask, 0.0)
        for mean in self._episode_means:
            mean.start(env_mask)
        self._draw_time_left(env_mask)
        self._resample(env_mask)
        self._update_command()
        self._start_episodes(env_mask)
        self._hold_fixed_command()
        return {}


class CommandManager:
    def __init__(self, cfg, env):
        self.env = env
        self.terms: dict[str, CommandTerm] = build_class_terms(cfg, env, "command")
        self.last_episode_metrics: dict[str, torch.Tensor] = {}
        """(N,) "<term>/<name>": each term metric of each env's most recently ended episode, as it stood at the
        end (evaluation reads it where an episode ended); preallocated, written in place."""
        for name, term in self.terms.items():
            for key, value in term.metrics.items():
                if value.shape != (env.num_envs,) or not value.is_floating_point():
                    raise ValueError(f"command '{name}': metrics['{key}'] must be a float tensor of one value per "
                                     f"env, shape ({env.num_envs},); got {value.dtype} of shape {tuple(value.shape)}")
                self.last_episode_metrics[f"{name}/{key}"] = torch.zeros_like(value)

    @property
    def active_terms(self) -> list[str]:
        return list(self.terms)

    def get_term(self, name: str) -> CommandTerm:
        if name not in self.terms:
            raise KeyError(f"no command term '{name}'. Terms: {self.active_terms}")
        return self.terms[name]

    def get_command(self, name: str) -> torch.Tensor:
        return self.get_term(name).command

    def compute(self, dt: float) -> None:
        for term in self.terms.values():
            term.compute(dt)

    def update_metrics(self) -> None:
        """Each term's per-step metrics; the env calls it after the physics, before resetting ended envs."""
        for term in self.terms.values():
            term.update_metrics()

    def finish_episodes(self, env_mask: torch.Tensor) -> dict:
        """End the episodes of the masked envs; the env calls it before their worlds are reset. Each term writes
        its end-of-episode values, then every metric of the masked envs goes to `last_episode_metrics`. Returns
        the log entries "Metrics/<term>/<name>": means over the masked envs (0 where none ends)."""
        count = env_mask.sum().clamp(min=1)
        log = {}
        for name, term in self.terms.items():
            term.finish_episodes(env_mask)
            for key, value in term.metrics.items():
                last = self.last_episode_metrics.get(f"{name}/{key}")
                if last is None:
                    raise RuntimeError(f"command '{name}': metrics['{key}'] appeared after the term was built; "
                                       "create every metric in the term's __init__ (a captured step cannot grow)")
                log[f"Metrics/{name}/{key}"] = keep_episode_end(value, last, env_mask, count)
        return log

    def reset(self, env_mask: torch.Tensor) -> dict:
        for term in self.terms.values():
            term.reset(env_mask)
        return {}
