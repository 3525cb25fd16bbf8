"""benchmark.py for a multi-agent task: the world's step against its robots' single-robot env.step.

Cost is wall time per simulated second. The multi-agent world (every agent acting at its own slots) is compared
with the sum of the costs of its agents' single-robot tasks (the registration's `single_agent_baselines`: the
task each agent's MDP comes from, with the overrides that give the agent's conditions and rate), each alone in
its own world of the same env count.
"""

from __future__ import annotations

import json
import time

from agile.run import task_setup
from agile.run.training_timing import synchronize


def seconds_per_simulated_second(step, simulated_s_per_call: float, calls: int, device) -> float:
    for _ in range(10):  # eager warm-up calls and the graph captures
        step()
    synchronize(device)
    start = time.perf_counter()
    for _ in range(calls):
        step()
    synchronize(device)
    return (time.perf_counter() - start) / (calls * simulated_s_per_call)


def measure_world(task: str, num_envs: int, device: str | None, calls: int, overrides: list[str]) -> dict:
    import torch

    from agile.run.multi_agent_world import make_world

    env_cfg, _, device = task_setup.load_task(task=task, num_envs=num_envs, device=device, overrides=overrides)
    world = make_world(task, env_cfg, device)
    dims = {n: a.action_manager.total_action_dim for n, a in world.agents.items()}

    def step():
        world.step({n: torch.rand(world.num_envs, dims[n], device=world.device) * 2 - 1
                    for n in world.acting_agents})

    cost = seconds_per_simulated_second(step, world.mean_slot_dt_s, calls, world.device)
    return {"num_envs": world.num_envs, "seconds_per_simulated_s": cost, "device": str(world.device)}


def measure_single(task: str, num_envs: int, device: str, calls: int, overrides: list[str]) -> dict:
    import torch

    env_cfg, _, device = task_setup.load_task(task=task, num_envs=num_envs, device=device, overrides=overrides)
    env = task_setup.make_env(task=task, env_cfg=env_cfg, device=device)
    dim = env.action_manager.total_action_dim

    def step():
        env.step(torch.rand(env.num_envs, dim, device=env.device) * 2 - 1)

    return {"task": task, "overrides": overrides, "control_hz": round(1.0 / env.step_dt, 3),
            "seconds_per_simulated_s": seconds_per_simulated_second(step, env.step_dt, calls, env.device)}


def benchmark(*, task: str, num_envs=(1024, 4096, 16384), device: str | None = None, steps: int = 200,
              overrides=()) -> list[dict]:
    """Measure a multi-agent task at each env count of `num_envs`: the world's wall seconds per simulated second
    (`steps` calls timed) against the sum of its agents' single-robot tasks (`single_agent_baselines` of its spec),
    each alone in its own world; a row per count, each printed as JSON when measured, then a table."""
    import agile.tasks

    baselines = agile.tasks.task_spec(task).single_agent_baselines
    rows = []
    for count in num_envs:
        world = measure_world(task, count, device, steps, list(overrides))
        singles = {agent: measure_single(t, count, world["device"], steps, list(o))
                   for agent, (t, o) in baselines.items()}
        total = sum(s["seconds_per_simulated_s"] for s in singles.values())
        row = {**world, "single_agent": singles, "sum_of_single_agent_s": total,
               "ratio_to_sum": world["seconds_per_simulated_s"] / total if singles else None}
        rows.append(row)
        print(json.dumps(row), flush=True)
    print(f"\n{task}: wall seconds per simulated second (lower is faster)")
    print(f"{'envs':>7} {'world':>10} {'sum of singles':>15} {'ratio':>6}  singles")
    for r in rows:
        singles = ", ".join(f"{a} {s['seconds_per_simulated_s']:.3f} ({s['task']} at {s['control_hz']:g} Hz)"
                            for a, s in r["single_agent"].items())
        ratio = f"{r['ratio_to_sum']:.2f}" if r["ratio_to_sum"] is not None else "-"
        print(f"{r['num_envs']:>7} {r['seconds_per_simulated_s']:>10.3f} {r['sum_of_single_agent_s']:>15.3f} "
              f"{ratio:>6}  {singles}")
    return rows


def benchmark_multi_agent(options) -> list[dict]:
    """`agile benchmark` for a multi-agent task (`options`: its `BenchmarkOptions`): `benchmark`'s rows, written as
    JSON to `out` where given."""
    rows = benchmark(task=options.task, num_envs=options.num_envs, device=options.device, steps=options.steps,
                     overrides=options.overrides)
    if options.out:
        with open(options.out, "w") as f:
            json.dump({"task": options.task, "results": rows}, f, indent=2)
    return rows
