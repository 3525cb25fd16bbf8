"""train and eval of a multi-agent task with HARL's HAPPO (`agile train --trainer happo`): checkpoints
happo_<iteration>.pt in the run folder, evaluated per agent as the per-group PPO runs are."""

from __future__ import annotations

from pathlib import Path

from agile.errors import AgileError
from agile.run import task_setup
from agile.utils.config import ConfigError

from agile.marl.happo_runner import CHECKPOINT_PREFIX


def newest_checkpoint(run_dir: str) -> str | None:
    """The newest happo_<iteration>.pt of a run folder; None where it holds none (a per-group PPO run)."""
    found = sorted(Path(run_dir).glob(f"{CHECKPOINT_PREFIX}*.pt"), key=lambda p: int(p.stem.split("_")[1]))
    return str(found[-1]) if found else None


def build_runner(world, cfg, log_dir: str | None, started_at: float | None = None):
    from agile.marl.happo_runner import HappoRunner

    try:
        return HappoRunner(world, cfg, log_dir, str(world.device), started_at=started_at)
    except ConfigError as err:
        raise AgileError(str(err)) from err


def check_observation_groups(env_cfg, cfg) -> None:
    """Refuse, before the world is built, an actor or critic group that some agent does not observe."""
    import dataclasses

    from agile.rl_env.managers import ObsGroup

    for name, agent in env_cfg.agents.items():
        groups = [f.name for f in dataclasses.fields(agent.observations)
                  if isinstance(getattr(agent.observations, f.name), ObsGroup)]
        for field in ("actor_group", "critic_group"):
            if getattr(cfg, field) not in groups:
                raise AgileError(f"agent.{field}={getattr(cfg, field)}: agent '{name}' has no such observation group; "
                                 f"its groups: {', '.join(groups)}")


def train(options):
    """`agile.run.train.train` with `options.trainer` "happo" (the task checked by `check_trainer`): a new run, its
    checkpoints in <log_root>/<experiment>/<time>_<run>/; a `TrainResult`."""
    from agile.run.multi_agent_world import make_world
    from agile.run.train import run_configs
    from agile.run.train_options import TrainResult

    started_at = options.started_at  # the checkpoints' wall time counts from the train call: imports, world build
    env_cfg, cfg, device = run_configs(options)
    check_observation_groups(env_cfg, cfg)
    world = make_world(options.task, env_cfg, device)
    log_dir = task_setup.new_log_dir(options.log_root, cfg.experiment_name, cfg.run_name)
    task_setup.dump_configs(log_dir, env_cfg, cfg)
    runner = build_runner(world, cfg, log_dir, started_at)
    print(f"[agile] HAPPO (harl-aht): actors {', '.join(runner.actors)}, critic on a state of "
          f"{runner.view.state_space.shape[0]}, {runner.slots_per_rollout} slots per rollout")
    runner.learn(cfg.max_iterations)
    checkpoint = newest_checkpoint(log_dir)
    print(f"[agile] logs and checkpoints in {log_dir}")
    return TrainResult(log_dir=log_dir, checkpoint=checkpoint, exported={})


def evaluate_run(world, run_dir: str, num_slots: int, recorders=(),
                 trust_checkpoint: bool = False) -> tuple[dict, dict]:
    """(per-agent metrics of `agile.run.multi_agent_world.evaluate`, {"happo": checkpoint}) of a HAPPO run folder's
    newest checkpoint, each actor acting on the mean of its action distribution."""
    from agile.marl.harl import AgentPolicyView, HappoCfg
    from agile.run.multi_agent_world import evaluate

    path = newest_checkpoint(run_dir)
    contents = task_setup.read_checkpoint(path, trust_checkpoint)
    saved = contents.get("cfg", {})
    unknown = sorted(set(saved) - set(HappoCfg.__dataclass_fields__))
    if unknown:
        raise AgileError(f"{path}: its HAPPO settings have fields this version does not know: {unknown}")
    runner = build_runner(world, HappoCfg(**saved), None)  # the networks as the run built them
    try:
        runner.load(contents, optimizers=False)
    except ConfigError as err:
        raise AgileError(f"{path}: {err}") from err
    for actor in runner.actors.values():
        actor.prep_rollout()
    policies = {AgentPolicyView(runner.view, name): act for name, act in runner.policies(deterministic=True).items()}
    return evaluate(world, policies, num_slots, recorders), {"happo": path}
