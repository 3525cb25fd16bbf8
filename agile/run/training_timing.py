"""How `agile benchmark` times a PPO training iteration, with the runner `agile train` trains with.

- `time_training`: one run of N iterations after a warm-up one, timed from one iteration's log to the next (the host's
  clock stamped by `SyncFreeLogger`): the mean (the training's iteration, the run's start and end left out), the
  median, the slowest and which of the run's it was, the run's mean with its ends; in that run, the PPO update's graph
  captures and Python's whole-heap garbage collections (what can make one iteration slow); then the phases of
  rsl-rl's loop, synchronised (host time) and, on CUDA, on the GPU's own clock.
"""

from __future__ import annotations

import gc
import statistics
import time

from agile.utils.heap import heap_frozen


def synchronize(device) -> None:
    import torch

    if str(device).startswith("cuda"):
        torch.cuda.synchronize()


@heap_frozen()  # as the runner's `learn` runs: the phases timed as training spends them
def training_loop(runner, env, iterations: int, phase) -> None:
    """rsl-rl's rollout and update (without its NaN checks and logging), each call made through `phase(name, func,
    *args)`, named "act", "env_step", "storage", "returns" or "update"."""
    import torch

    alg = runner.alg
    obs = env.get_observations()
    for _ in range(iterations):
        with torch.inference_mode():
            for _ in range(runner.cfg["num_steps_per_env"]):
                actions = phase("act", alg.act, obs)
                obs, rewards, dones, extras = phase("env_step", env.step, actions)
                phase("storage", alg.process_env_step, obs, rewards, dones, extras)
            phase("returns", alg.compute_returns, obs)
        phase("update", alg.update)


PHASE_GROUPS = {"act": "policy_and_storage_s", "env_step": "env_steps_s", "storage": "policy_and_storage_s",
                "returns": "policy_and_storage_s", "update": "update_s"}
"""Where `time_training_phases` counts each call of `training_loop`."""


def time_training_phases(runner, env, iterations: int) -> dict:
    """Seconds per PPO iteration in each phase of rsl-rl's loop (`training_loop`): env steps, policy inference with
    rollout storage, and the update. Each phase is closed by a device synchronisation, so the sum is a little above a
    real iteration."""
    device = env.device
    seconds = {"env_steps_s": 0.0, "policy_and_storage_s": 0.0, "update_s": 0.0}

    def timed(name: str, func, *args):
        synchronize(device)
        start = time.perf_counter()
        result = func(*args)
        synchronize(device)
        seconds[PHASE_GROUPS[name]] += time.perf_counter() - start
        return result

    training_loop(runner, env, iterations, timed)
    return {name: value / iterations for name, value in seconds.items()}


def time_training_timeline(runner, env, iterations: int) -> dict | None:
    """The loop's calls (`training_loop`: act, env step, storage, returns, update) on the GPU's own clock, nothing
    synchronised: a CUDA event recorded after each call and read once at the end. A phase's time runs from the end of
    the call before on the GPU, so it includes the GPU's waits for the host to launch it: where `time_training_phases`
    (synchronised, host time) and this differ, the host was the bottleneck, or hid behind the GPU. `loop_s`: the
    host's wall time of the loop; None off CUDA."""
    import torch

    if not str(env.device).startswith("cuda"):
        return None
    seconds = {f"{name}_s": 0.0 for name in PHASE_GROUPS}
    last = torch.cuda.Event(enable_timing=True)
    marks: list[tuple[str, torch.cuda.Event]] = []

    def marked(name: str, func, *args):
        result = func(*args)
        event = torch.cuda.Event(enable_timing=True)
        event.record()
        marks.append((name, event))
        return result

    synchronize(env.device)
    start = time.perf_counter()
    last.record()
    training_loop(runner, env, iterations, marked)
    synchronize(env.device)
    loop_s = time.perf_counter() - start
    for name, event in marks:
        seconds[f"{name}_s"] += last.elapsed_time(event) / 1e3
        last = event
    return {**{name: value / iterations for name, value in seconds.items()}, "loop_s": loop_s / iterations}


def timed_learn(runner, iterations: int) -> float:
    """Seconds of `runner.learn(iterations)`, the device's queued work done before and after."""
    synchronize(runner.device)
    start = time.perf_counter()
    runner.learn(iterations)
    synchronize(runner.device)
    return time.perf_counter() - start


class FullGarbageCollections:
    """Python's collections of the whole heap (generation 2) while entered, counted and timed: a pass over every
    object of a process holding a simulator (~1.3 million for G1), about half a second on a CPU core, which lands in
    whichever iteration triggers it; `learn` freezes what exists at its start (`agile.utils.heap`), so a pass within
    it visits only what the training created."""

    def __init__(self):
        self.count = 0
        self.seconds = 0.0
        self._started_s: float | None = None

    def __enter__(self) -> FullGarbageCollections:
        gc.callbacks.append(self._observe)
        return self

    def __exit__(self, *exc) -> None:
        gc.callbacks.remove(self._observe)

    def _observe(self, phase: str, info: dict) -> None:
        if info["generation"] != 2:
            return
        if phase == "start":
            self._started_s = time.perf_counter()
        elif self._started_s is not None:
            self.count += 1
            self.seconds += time.perf_counter() - self._started_s
            self._started_s = None


def iteration_times(stamps_s: list[float]) -> dict:
    """Whole iterations of a run from the host's clock at each iteration's log (`SyncFreeLogger.iteration_stamps_s`):
    the time from one log to the next is an iteration with everything the runner does in it (rollout, update, log,
    a checkpoint saved on the way). Their mean is the training's iteration, the run's start (before the first log)
    and end (the last checkpoint saved, the log closed) left out; the median and the slowest are beside it, so that
    one slow iteration (a checkpoint, a capture) shows as such."""
    intervals = [b - a for a, b in zip(stamps_s, stamps_s[1:])]
    if not intervals:
        raise ValueError(f"iteration times need at least two iterations' stamps, got {len(stamps_s)}")
    slowest = max(range(len(intervals)), key=intervals.__getitem__)
    return {"iteration_s": (stamps_s[-1] - stamps_s[0]) / len(intervals),
            "iteration_median_s": statistics.median(intervals), "iteration_slowest_s": intervals[slowest],
            "iteration_slowest_of_run": slowest + 2}  # the timed run's iterations counted from 1; the first has no start


def time_training(runner, iterations: int) -> dict:
    """Everything above for a fresh training runner (see the module's docstring); `iterations` >= 2."""
    runner.learn(1)  # warm-up: allocations, first update
    captures_before = getattr(runner.alg, "captures_made", 0)  # a captured PPO update (captured_update) records anew
    with FullGarbageCollections() as collections:
        run_s = timed_learn(runner, iterations)
    stamps_s = [stamp for _, stamp in runner.logger.iteration_stamps_s][-iterations:]
    phases = time_training_phases(runner, runner.env, iterations)
    return {**iteration_times(stamps_s), "iteration_with_run_ends_s": run_s / iterations,
            "ppo_update_captures_in_run": getattr(runner.alg, "captures_made", 0) - captures_before,
            "full_gc_collections_in_run": collections.count, "full_gc_s_in_run": collections.seconds,
            **{f"iteration_{phase}": value for phase, value in phases.items()},
            "iteration_gpu_timeline": time_training_timeline(runner, runner.env, iterations)}
