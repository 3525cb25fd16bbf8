"""rsl-rl's training logger without a host synchronisation at every env step.

rsl-rl's `Logger.process_env_step` finds the episodes that just ended with `nonzero` and copies their returns and
lengths to the host, every env step: the host waits for the GPU to finish that step before it may launch the
policy's next inference, so the GPU idles while Python launches the policy's and the storage's small kernels (a
rollout's host launches are otherwise hidden behind the previous env step's graph). `SyncFreeLogger` writes each
step's finished episodes into device buffers (one row per step of the rollout) and moves them to the host once per
iteration, when it logs: the same returns and lengths, in the same order (step by step, env by env), in the same
100-episode windows (`rewbuffer`, `lenbuffer`) that rsl-rl's report and tensorboard read. The episode extras
(`extras["log"]`) are averaged over the rollout in one reduction before rsl-rl's `log` reads them.

The log itself is written one env step late: `log` (after the update) starts one asynchronous copy to the host of
every number the log reads (the held episodes, the averaged extras, the action std, tensor losses) and returns; the
next env step's `process_env_step`, called once that step is on the GPU, writes it (tensorboard, the console block)
from the host copies while the GPU steps. rsl-rl's `log` read each of its ~60 scalars back separately (120 host
synchronisations an iteration) and formatted and wrote them while the GPU idled between the update and the next
rollout. A pending log is also written before a checkpoint is uploaded (`save_model`), when the run stops
(`stop_logging_writer`) and before another `log`. The block and the scalars are rsl-rl's: its `log` runs on the host
copies (`write_log`, which the progress loggers override).

The training runners (`CheckpointingRunner`) use it, and the progress loggers (`agile.rl_env.rsl_rl.progress`)
build on it. With RND's intrinsic rewards it keeps rsl-rl's per-step bookkeeping (none of our tasks uses RND).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from rsl_rl.utils.logger import Logger


def rebuilt_logger(cls, logger: Logger, runner) -> Logger:
    """The runner's logger (log dir, config, buffers) as a `cls`, built with the arguments the runner gave its own,
    before training starts (rsl-rl creates the tensorboard writer in `learn`)."""
    new = cls(log_dir=logger.log_dir, cfg=logger.cfg, env_cfg=logger.env_cfg, num_envs=logger.num_envs,
              is_distributed=runner.is_distributed, gpu_world_size=runner.gpu_world_size,
              gpu_global_rank=runner.gpu_global_rank, device=getattr(logger, "step_device", logger.device))
    new.git_status_repos = logger.git_status_repos
    new.block_title = getattr(logger, "block_title", None)
    return new


class SyncFreeLogger(Logger):
    block_title: str | None = None
    """A line printed above each of rsl-rl's log blocks (a multi-agent run names the group)."""

    def __init__(self, *args, device: str | torch.device, **kwargs):
        # rsl-rl's `log` averages the extras on `device`: the host copies here, so the log never waits on the GPU
        super().__init__(*args, device="cpu", **kwargs)
        self.step_device = torch.device(device)
        """Where the env steps' tensors live: the per-env sums and the held steps."""
        self.cur_reward_sum = torch.zeros(self.num_envs, device=self.step_device)
        self.cur_episode_length = torch.zeros(self.num_envs, device=self.step_device)
        if self.cfg["algorithm"].get("rnd_cfg"):
            self.cur_ereward_sum = torch.zeros(self.num_envs, device=self.step_device)
            self.cur_ireward_sum = torch.zeros(self.num_envs, device=self.step_device)
        rows = max(1, int(self.cfg.get("num_steps_per_env", 1)))  # a rollout's steps: one flush per iteration
        self.ended = torch.zeros(rows, self.num_envs, dtype=torch.bool, device=self.step_device)
        """(steps, N): which envs' episodes ended at each step held since the last flush."""
        self.ended_return = torch.zeros(rows, self.num_envs, device=self.step_device)
        """(steps, N): the return summed up to each step (read where `ended`)."""
        self.ended_length_steps = torch.zeros(rows, self.num_envs, device=self.step_device)
        self.steps_held = 0
        self.pending: PendingLog | None = None
        """The last `log`, its numbers on their way to the host, until it is written."""

    def process_env_step(self, rewards: torch.Tensor, dones: torch.Tensor, extras: dict,
                         intrinsic_rewards: torch.Tensor | None = None) -> None:
        self.write_pending_log()  # this step is on the GPU now: the host writes the last log meanwhile
        if self.writer is None or intrinsic_rewards is not None:
            super().process_env_step(rewards, dones, extras, intrinsic_rewards)
            return
        if "episode" in extras:
            self.ep_extras.append(extras["episode"])
        elif "log" in extras:
            self.ep_extras.append(extras["log"])
        self.cur_reward_sum += rewards
        self.cur_episode_length += 1
        if self.steps_held == len(self.ended):  # more steps than a rollout's before a log (a longer loop)
            self.flush_ended_episodes()
        row, ended = self.steps_held, dones > 0
        self.ended[row] = ended
        self.ended_return[row] = self.cur_reward_sum
        self.ended_length_steps[row] = self.cur_episode_length
        self.cur_reward_sum.masked_fill_(ended, 0.0)
        self.cur_episode_length.masked_fill_(ended, 0.0)
        self.steps_held += 1

    def flush_ended_episodes(self) -> None:
        """Move the held steps' ended episodes into rsl-rl's windows now (one host synchronisation)."""
        if self.steps_held:
            self.keep_episodes(*HostCopy(self.take_held_steps()).wait())

    def take_held_steps(self) -> list[torch.Tensor]:
        """(ended, return, length) of the steps held since the last flush, (steps, N) each; the rows are free again."""
        held = slice(0, self.steps_held)
        self.steps_held = 0
        return [self.ended[held], self.ended_return[held], self.ended_length_steps[held]]

    def keep_episodes(self, ended: torch.Tensor, returns: torch.Tensor, lengths: torch.Tensor) -> None:
        """Host copies of held steps into rsl-rl's windows: the ended episodes, step by step, env by env."""
        self.rewbuffer.extend(returns[ended].tolist())
        self.lenbuffer.extend(lengths[ended].tolist())

    def average_episode_extras(self) -> None:
        """Replace the held steps' extras by their means over the steps, where every step holds the same keys as
        0-d tensors (the env's `extras["log"]`): rsl-rl's `log` then averages one value per key, the same means,
        instead of concatenating every step's value of every key one small op at a time (58 keys x 24 steps for
        G1: ~3,000 launches an iteration, the GPU idle meanwhile)."""
        extras = self.ep_extras
        if not extras:
            return
        keys = list(extras[0])
        scalar_tensors = all(isinstance(value, torch.Tensor) and value.dim() == 0 for value in extras[0].values())
        if not keys or not scalar_tensors or any(list(step) != keys for step in extras):
            return
        per_step = torch.stack([torch.stack([value.float() for value in step.values()]) for step in extras])
        self.ep_extras = [dict(zip(keys, per_step.mean(dim=0).unsqueeze(1)))]

    def log(self, **kwargs) -> None:
        """Start moving what rsl-rl's `log` reads (`kwargs` as it takes them) to the host; written later."""
        self.write_pending_log()
        if self.writer is None:  # another rank of a multi-GPU run: rsl-rl's log writes nothing there
            return
        self.average_episode_extras()
        episodes = self.take_held_steps()
        extras, self.ep_extras = self.ep_extras, []
        extra_tensors = [(step, key) for step, values in enumerate(extras) for key, value in values.items()
                         if isinstance(value, torch.Tensor)]
        loss_dict = dict(kwargs["loss_dict"])
        loss_tensors = [key for key, value in loss_dict.items() if isinstance(value, torch.Tensor)]
        tensors = episodes + [extras[step][key] for step, key in extra_tensors] + [loss_dict[key] for key in loss_tensors]
        tensors.append(kwargs["action_std"])
        self.pending = PendingLog(kwargs, extras, extra_tensors, loss_tensors, HostCopy(tensors))

    def write_pending_log(self) -> None:
        """Write the pending log, if any, from its host copies (waits for the copy, not for later GPU work)."""
        if self.pending is None:
            return
        pending, self.pending = self.pending, None
        host = pending.copy.wait()
        self.keep_episodes(*host[:3])
        values = iter(host[3:])
        extras = [dict(step) for step in pending.extras]
        for step, key in pending.extra_tensors:
            extras[step][key] = next(values)
        kwargs = dict(pending.kwargs)
        kwargs["loss_dict"] = dict(kwargs["loss_dict"])
        for key in pending.loss_tensors:
            kwargs["loss_dict"][key] = next(values).item()
        kwargs["action_std"] = next(values)
        held_now, self.ep_extras = self.ep_extras, extras  # (a log written before the next step holds none)
        self.write_log(**kwargs)
        self.ep_extras = held_now

    def write_log(self, **kwargs) -> None:
        """rsl-rl's `log` (tensorboard scalars, the console block) on host values."""
        if self.block_title:
            print(self.block_title)
        super().log(**kwargs)

    def save_model(self, path: str, it: int) -> None:
        self.write_pending_log()  # an iteration's log before its checkpoint
        super().save_model(path, it)

    def stop_logging_writer(self) -> None:
        self.write_pending_log()
        # the last log is on disk when `learn` returns: tensorboard writes from a thread, and a write after the caller
        # removed the log dir re-created the event file in it (a benchmark's temporary dir: "Directory not empty")
        flush = getattr(self.writer, "flush", None)
        if flush is not None:
            flush()
        super().stop_logging_writer()


class HostCopy:
    """Tensors moved to the host together: concatenated on their device, copied asynchronously into page-locked
    memory (one launch, one event), given back with their shapes and dtypes by `wait`."""

    def __init__(self, tensors: list[torch.Tensor]):
        self.layout = [(tensor.shape, tensor.dtype) for tensor in tensors]
        flat = torch.cat([tensor.detach().reshape(-1).to(torch.float64) for tensor in tensors])
        self.on_gpu = flat.is_cuda
        self.host = torch.empty(flat.shape, dtype=flat.dtype, pin_memory=self.on_gpu)
        self.host.copy_(flat, non_blocking=self.on_gpu)
        self.done = torch.cuda.Event() if self.on_gpu else None
        if self.done is not None:
            self.done.record()

    def wait(self) -> list[torch.Tensor]:
        if self.done is not None:
            self.done.synchronize()
        tensors, start = [], 0
        for shape, dtype in self.layout:
            size = shape.numel()
            tensors.append(self.host[start:start + size].reshape(shape).to(dtype))
            start += size
        return tensors


@dataclass
class PendingLog:
    kwargs: dict
    """rsl-rl's `log` arguments, as given."""
    extras: list[dict]
    """The episode extras as held (tensors still on the device)."""
    extra_tensors: list[tuple[int, str]]
    """(step, key) of each extra that is a tensor, in the copy's order."""
    loss_tensors: list[str]
    """The losses given as tensors, in the copy's order."""
    copy: HostCopy
