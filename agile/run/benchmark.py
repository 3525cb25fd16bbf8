"""Throughput of a task: raw physics, full env.step, and training, in env-steps per second.

    agile benchmark --task Velocity-G1-History-v0 --num_envs 1024 4096 16384
    agile benchmark --task Velocity-T1-v0 --device cpu --num_envs 2 --steps 20   # a CPU check

For each env count, from one process on one device: raw physics (the captured decimation loop alone, no
managers, from the state the env has after one second of random actions), env.step with random actions and
its ratio to raw physics, PPO training (rollout + update, with the training's runner, logger and NaN check as
`agile train` runs them, logging into a temporary folder; per iteration of a long training: the host's time from
one iteration's log to the next over a run of --train_iterations, so that the run's start and end, its log opened and
closed and its last checkpoint saved, are left out; with the median and slowest iteration, and the run's mean with its
ends) and its ratio, startup (gym.make to the first step
done), device memory in use, the share of the env step spent in the explicit actuators (raw physics with and
without them), the solver iterations of the slowest world under raw physics and under env.step (untimed),
and where a training iteration's time goes (env steps, policy inference and rollout storage, PPO update: each phase
synchronised, in host time; on CUDA also unsynchronised, on the GPU's clock), and the peak demand on the solver's
constraint rows (njmax) and contacts. For a task on a terrain, the raw physics of the same robot on flat ground (no
terrain, contact sensor or height rays) is measured first in a separate world, and the env.step and training rates
are also given as ratios to it.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import tempfile
import time

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError
from agile.run.training_timing import synchronize, time_training


@dataclasses.dataclass(frozen=True)
class BenchmarkOptions:
    """Everything `agile benchmark` measures with, for a task of any kind (`agile.run.task_kinds`: the kind's benchmark
    function takes it): the env counts `num_envs`, one after another; `steps` timed per measurement; `recipe`: the
    name of the recipe (agile.run.recipes) whose overrides are at the front of `overrides`, recorded in `out` (the
    results as JSON)."""
    task: str
    num_envs: tuple = (1024, 4096, 16384)
    device: str | None = None
    steps: int = 200
    train_iterations: int = 20
    overrides: tuple = ()
    recipe: str | None = None
    out: str | None = None


RUNNING_STATE_ENV_STEPS = 50
"""Env steps with random actions (1 s at 50 Hz) before raw physics is timed, so that it is timed from the
states env.step visits, not from the spawn."""


def device_memory_used_gb(device) -> float | None:
    import torch

    if not str(device).startswith("cuda"):
        return None
    free, total = torch.cuda.mem_get_info()
    return (total - free) / 1e9


def restarter(sim):
    """A function that puts every world back into the state it has now (entities, solver warm start cleared)."""
    import torch
    import warp as wp

    all_worlds = torch.ones(sim.num_envs, dtype=torch.bool, device=sim.device)
    coords, dofs = wp.to_torch(sim.state.joint_q), wp.to_torch(sim.state.joint_qd)
    start_state = (coords.clone(), dofs.clone())

    def restart() -> None:
        sim.reset_worlds(all_worlds)  # first: the solver's reset also puts the joint state back to the model's
        coords.copy_(start_state[0])
        dofs.copy_(start_state[1])
        sim.forward()

    return restart


def slowest_world_solver_iterations(sim, advance, steps: int, restart=None, chunk_steps: int = 10) -> float:
    """Untimed: the slowest world's solver iterations in the last physics step of each env step, averaged over
    `steps` calls of `advance` (restarting every `chunk_steps` when `restart` is given, as `time_physics` does).
    On a GPU the solver loops until that world converges, so a figure that differs between raw physics and
    env.step tells the two are not paying for the same physics."""
    total = 0.0
    for i in range(steps):
        if restart is not None and i % chunk_steps == 0:
            restart()
        advance()
        total += sim.solver_iterations().max().item()
    if restart is not None:
        restart()
    return total / steps


def time_physics(sim, decimation: int, steps: int, chunk_steps: int = 10) -> float:
    """env-steps/s of the captured decimation loop alone (with the actuators), no managers.

    Without a policy the robots fall over, and fallen robots on a terrain touch many more triangles than
    standing ones (the rate then depends on how long the measurement ran): every chunk of `chunk_steps`
    env steps starts again from the state the world had at the call, restored outside the timed region."""
    restart = restarter(sim)
    for _ in range(5):
        sim.step(decimation)
    elapsed_s, done = 0.0, 0
    while done < steps:
        restart()
        chunk = min(chunk_steps, steps - done)
        synchronize(sim.device)
        start = time.perf_counter()
        for _ in range(chunk):
            sim.step(decimation)
        synchronize(sim.device)
        elapsed_s += time.perf_counter() - start
        done += chunk
    restart()
    return sim.num_envs * steps / elapsed_s


def flat_raw_physics(env_cfg, device: str, steps: int) -> float:
    """Raw physics of the task's scene on a ground plane (no terrain, contact sensors or height rays), in a
    world of its own, released before returning."""
    from agile.sim import Simulation

    flat_scene = copy.deepcopy(env_cfg.scene)
    flat_scene.terrain, flat_scene.contact_sensors, flat_scene.height_scanners = None, {}, {}
    sim = Simulation(env_cfg.sim, flat_scene, env_cfg.num_envs, device, env_cfg.sim.physics_dt_s * env_cfg.decimation)
    rate = time_physics(sim, env_cfg.decimation, steps)
    del sim
    return rate


def measure(task: str, env_cfg, agent_cfg, device: str, steps: int, train_iterations: int) -> dict:
    import torch

    from agile.rl_env import ManagerBasedRLEnv
    from agile.rl.runner import training_runner

    flat_raw = flat_raw_physics(env_cfg, device, steps) if env_cfg.scene.terrain is not None else None
    start = time.perf_counter()
    env = ManagerBasedRLEnv(env_cfg, task_name=task, device=device)
    n = env.num_envs
    action_dim = env.action_manager.total_action_dim
    env.step(torch.zeros(n, action_dim, device=env.device))
    synchronize(env.device)
    startup_s = time.perf_counter() - start

    # Raw physics starts from a state env.step visits: right after the spawn the robots land (randomised
    # pose, joints and velocities), which on a terrain is dearer than a running env's step.
    for _ in range(RUNNING_STATE_ENV_STEPS):
        env.step(torch.rand(n, action_dim, device=env.device) * 2 - 1)
    raw = time_physics(env.sim, env.cfg.decimation, steps)
    raw_iterations = slowest_world_solver_iterations(env.sim, lambda: env.sim.step(env.cfg.decimation), 20,
                                                     restart=restarter(env.sim))
    with env.sim.actuators_disabled():
        raw_without_actuators = time_physics(env.sim, env.cfg.decimation, steps)
    env.reset()

    actions = torch.rand(steps, n, action_dim, device=env.device) * 2 - 1
    for i in range(5):
        env.step(actions[i])
    synchronize(env.device)
    start = time.perf_counter()
    for i in range(steps):
        env.step(actions[i])
    synchronize(env.device)
    full = n * steps / (time.perf_counter() - start)
    env_step_iterations = slowest_world_solver_iterations(
        env.sim, lambda: env.step(torch.rand_like(actions[0]) * 2 - 1), 20)

    agent_cfg.max_iterations = train_iterations
    with tempfile.TemporaryDirectory() as log_dir, task_setup.quiet_stdout():
        training = time_training(training_runner(env, agent_cfg, log_dir), train_iterations)
    steps_per_iteration = n * agent_cfg.num_steps_per_env
    train = steps_per_iteration / training["iteration_s"]
    memory = device_memory_used_gb(env.device)
    # the demand on the solver's fixed buffers over everything above (random actions, falls, training)
    capacity = env.sim.capacity
    buffers = {"peak_constraint_rows_per_world": int(capacity.peak_constraint_rows.item()), "njmax": capacity.njmax,
               "constraint_row_overflows": int(capacity.constraint_row_overflows.item()),
               "peak_contacts_mean_per_world": int(capacity.peak_contacts.item()) / n,
               "contact_capacity_per_world": capacity.contact_capacity / n}
    env.close()
    actuator_s = n / raw - n / raw_without_actuators  # per env step
    result = {"num_envs": n, "raw_physics": raw, "raw_physics_without_actuators": raw_without_actuators,
              "actuator_share_of_env_step": actuator_s / (n / full), "env_step": full, "env_step_ratio": full / raw,
              "train": train, "train_ratio": train / raw, "startup_s": startup_s, "device_memory_gb": memory,
              "solver_iterations_slowest_world_raw": raw_iterations,
              "solver_iterations_slowest_world_env_step": env_step_iterations,
              **training, "train_with_run_ends": steps_per_iteration / training["iteration_with_run_ends_s"],
              **buffers}
    if flat_raw is not None:
        result.update(flat_raw_physics=flat_raw, env_step_ratio_to_flat=full / flat_raw,
                      train_ratio_to_flat=train / flat_raw)
    return result


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--task", required=True, help="registered task ID, e.g. Velocity-G1-History-v0")
    parser.add_argument("--num_envs", type=int, nargs="+", default=[1024, 4096, 16384],
                        help="env counts to measure, one after another")
    parser.add_argument("--device", default=None, help="cuda:0 or cpu (default: cuda:0 when a GPU is present)")
    parser.add_argument("--steps", type=int, default=200, help="env steps timed per measurement")
    parser.add_argument("--train_iterations", type=int, default=20,
                        help="PPO iterations of the timed run for the training rate (after one untimed; at least 2)")
    parser.add_argument("--out", default=None, help="write the results as JSON here")
    parser.add_argument("overrides", nargs="*", help=arguments.OVERRIDE_HELP)
    arguments.add_recipe_arg(parser)
    args = arguments.parse(parser, argv)
    if args.train_iterations < 2:  # refused before the simulator is imported (`benchmark` refuses it too)
        raise AgileError(f"--train_iterations must be at least 2 (an iteration is timed from one iteration's log to "
                         f"the next), got {args.train_iterations}")

    from agile.run.task_kinds import run_command

    options = BenchmarkOptions(task=args.task, num_envs=tuple(args.num_envs), device=args.device, steps=args.steps,
                               train_iterations=args.train_iterations, overrides=tuple(args.overrides),
                               recipe=args.recipe, out=args.out)
    run_command("benchmark", options.task, options)


def benchmark(*, task: str, num_envs=(1024, 4096, 16384), device: str | None = None, steps: int = 200,
              train_iterations: int = 20, overrides=()) -> list[dict]:
    """Measure `task` at each env count of `num_envs`, one after another (`measure`: raw physics, env.step and
    training rates, startup, memory, where an iteration goes); a row per count, each printed as JSON when measured."""
    import torch

    if train_iterations < 2:
        raise AgileError(f"train_iterations must be at least 2 (an iteration is timed from one iteration's log to the "
                         f"next), got {train_iterations}")
    rows = []
    for count in num_envs:
        env_cfg, agent_cfg, device_used = task_setup.load_task(task=task, num_envs=count, device=device,
                                                               overrides=overrides)
        rows.append(measure(task, env_cfg, agent_cfg, device_used, steps, train_iterations))
        print(json.dumps(rows[-1]), flush=True)
        if device_used.startswith("cuda"):
            torch.cuda.empty_cache()
    return rows


def benchmark_single_agent(options: BenchmarkOptions) -> list[dict]:
    """`agile benchmark` for every kind but multi-agent (`agile.run.task_kinds`): `benchmark`'s rows, their tables
    printed, and written as JSON to `out` where given."""
    import torch

    rows = benchmark(task=options.task, num_envs=options.num_envs, device=options.device, steps=options.steps,
                     train_iterations=options.train_iterations, overrides=options.overrides)
    device, _ = task_setup.resolve_device(options.device)

    name = torch.cuda.get_device_name() if str(device).startswith("cuda") else "CPU"
    print(f"\n{options.task} on {name} (env-steps/s; ratios to raw physics)")
    print(f"{'envs':>7} {'raw physics':>12} {'env.step':>10} {'ratio':>6} {'train':>10} {'ratio':>6} "
          f"{'startup s':>9} {'mem GB':>7} {'actuators':>9}")
    for r in rows:
        mem = f"{r['device_memory_gb']:.1f}" if r["device_memory_gb"] is not None else "-"
        print(f"{r['num_envs']:>7} {r['raw_physics']:>12.0f} {r['env_step']:>10.0f} {r['env_step_ratio']:>6.2f} "
              f"{r['train']:>10.0f} {r['train_ratio']:>6.2f} {r['startup_s']:>9.1f} {mem:>7} "
              f"{100 * r['actuator_share_of_env_step']:>8.1f}%")
    print("\nwhere a PPO iteration goes (s): the runner's iteration (log to log: mean, median, slowest and which of the "
          "run's; the run's mean with its start and end), then its phases timed one by one (env steps, policy "
          "inference and rollout storage, PPO update)")
    print(f"{'envs':>7} {'iteration':>10} {'median':>8} {'slowest':>12} {'with ends':>10} {'env steps':>10} "
          f"{'policy':>8} {'update':>8}")
    for r in rows:
        slowest = f"{r['iteration_slowest_s']:.3f} (#{r['iteration_slowest_of_run']})"
        print(f"{r['num_envs']:>7} {r['iteration_s']:>10.3f} {r['iteration_median_s']:>8.3f} {slowest:>12} "
              f"{r['iteration_with_run_ends_s']:>10.3f} {r['iteration_env_steps_s']:>10.3f} "
              f"{r['iteration_policy_and_storage_s']:>8.3f} {r['iteration_update_s']:>8.3f}")
        print(f"{'':>7} in the timed run: the PPO update captured {r['ppo_update_captures_in_run']} time(s), "
              f"{r['full_gc_collections_in_run']} whole-heap garbage collection(s) ({r['full_gc_s_in_run']:.3f} s)")
    timelines = [r for r in rows if r["iteration_gpu_timeline"]]
    if timelines:
        print("\nthe same phases on the GPU's clock, unsynchronised (s per iteration; a phase includes the GPU's wait "
              "for the host to launch it), and the host's wall time of that loop")
        print(f"{'envs':>7} {'act':>8} {'env step':>9} {'storage':>8} {'returns':>8} {'update':>8} {'loop':>8}")
        for r in timelines:
            t = r["iteration_gpu_timeline"]
            print(f"{r['num_envs']:>7} {t['act_s']:>8.3f} {t['env_step_s']:>9.3f} {t['storage_s']:>8.3f} "
                  f"{t['returns_s']:>8.3f} {t['update_s']:>8.3f} {t['loop_s']:>8.3f}")
    print("\nsolver iterations per physics step of the slowest world (a GPU step waits for it), untimed")
    print(f"{'envs':>7} {'raw physics':>12} {'env.step':>10}")
    for r in rows:
        print(f"{r['num_envs']:>7} {r['solver_iterations_slowest_world_raw']:>12.1f} "
              f"{r['solver_iterations_slowest_world_env_step']:>10.1f}")
    print("\nthe solver's buffers per world: peak demand over the run (random actions, falls, training) and size")
    print(f"{'envs':>7} {'rows':>6} {'njmax':>6} {'over':>6} {'contacts':>9} {'capacity':>9}"
          "  (contacts: all worlds' peak / worlds)")
    for r in rows:
        print(f"{r['num_envs']:>7} {r['peak_constraint_rows_per_world']:>6} {r['njmax']:>6} "
              f"{r['constraint_row_overflows']:>6} {r['peak_contacts_mean_per_world']:>9.1f} "
              f"{r['contact_capacity_per_world']:>9.0f}")
    flat_rows = [r for r in rows if "flat_raw_physics" in r]
    if flat_rows:
        print("\nthe same robot on flat ground (raw physics) and the ratios to it")
        print(f"{'envs':>7} {'flat raw':>12} {'env.step':>10} {'ratio':>6} {'train':>10} {'ratio':>6}")
        for r in flat_rows:
            print(f"{r['num_envs']:>7} {r['flat_raw_physics']:>12.0f} {r['env_step']:>10.0f} "
                  f"{r['env_step_ratio_to_flat']:>6.2f} {r['train']:>10.0f} {r['train_ratio_to_flat']:>6.2f}")
    if options.out:
        with open(options.out, "w") as f:
            json.dump({"task": options.task, "device": name, "recipe": options.recipe,
                       "overrides": list(options.overrides), "results": rows}, f, indent=2)
    return rows


if __name__ == "__main__":
    main()
