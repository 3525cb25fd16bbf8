"""train of a single-agent task with FastTD3 (`agile train --trainer fast_td3`, `agile.rl.fast_td3`): checkpoints
model_<iteration>.pt in the run folder whose actor `agile eval`, `play`, `export` and `time_to_policy` load as they
load a PPO checkpoint's, and the exported policy at the end."""

from __future__ import annotations

import os
from pathlib import Path

from agile.errors import AgileError
from agile.run import task_setup
from agile.utils.config import ConfigError


def train(options):
    """`agile.run.train.train` with `options.trainer` "fast_td3" (the task and options checked by `check_trainer`):
    a new run, its checkpoints in <log_root>/<experiment>/<time>_<run>/; a `TrainResult`."""
    from agile.rl import RslRlVecEnvWrapper
    from agile.rl.checkpoints import load_checkpoint
    from agile.rl.configs import set_matmul_precision
    from agile.rl.fast_td3 import FastTd3Runner
    from agile.run.export import export
    from agile.run.policy import load_runner
    from agile.run.train import TrainResult, run_configs, save_interrupted, warn_many_envs_on_cpu

    env_cfg, cfg, device = run_configs(options)
    try:
        cfg.check()
    except ConfigError as err:
        raise AgileError(f"agent.{err}") from err
    warn_many_envs_on_cpu(env_cfg.num_envs, device)
    env = task_setup.make_env(task=options.task, env_cfg=env_cfg, device=device)
    log_dir = task_setup.new_log_dir(options.log_root, cfg.experiment_name, cfg.run_name)
    task_setup.dump_configs(log_dir, env_cfg, cfg)
    set_matmul_precision(cfg.policy)
    runner = FastTd3Runner(RslRlVecEnvWrapper(env), cfg, log_dir, device, overrides=options.overrides)
    print(f"[agile] FastTD3 on {options.task}: {task_setup.plural(env.num_envs, 'env')} on {device}, "
          f"replay {cfg.buffer_steps_per_env} steps per env, batch {cfg.batch_size}, {cfg.updates_per_step} "
          f"updates per env step, actions within ±{cfg.action_bound:g}", flush=True)
    try:
        runner.learn(cfg.max_iterations)
    except KeyboardInterrupt:
        saved = save_interrupted(runner, log_dir)
        print(f"\n[agile] training interrupted at iteration {runner.current_learning_iteration}: its weights saved "
              f"in {saved}", flush=True)
        raise
    checkpoints = sorted(Path(log_dir).glob("model_*.pt"), key=lambda p: int(p.stem.split("_")[1]))
    policy_runner = load_runner(load_checkpoint(str(checkpoints[-1])), env, cfg.policy)
    exported = export(options.task, env, cfg.policy, policy_runner, os.path.join(log_dir, "exported"))
    print(f"[agile] logs and checkpoints in {log_dir}; exported policy in {os.path.dirname(exported['jit'])}")
    env.close()
    return TrainResult(log_dir=log_dir, checkpoint=str(checkpoints[-1]), exported=exported)
