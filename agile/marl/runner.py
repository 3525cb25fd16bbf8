"""MultiAgentRunner: every agent group's RSL-RL learner fed from one synchronous stepping of the world."""

from __future__ import annotations

import os
import time

import torch

from agile.marl.env import MultiAgentEnv
from agile.marl.rsl_rl import GroupVecEnv, MultiAgentRunnerCfg
from agile.rl import to_rsl_rl_dict
from agile.rl.runner import CheckpointingRunner
from agile.utils.config import ConfigError
from agile.utils.heap import heap_frozen


def rollout_physics_steps(world: MultiAgentEnv, rollout_s: float) -> int:
    """Physics steps of a rollout of `rollout_s` simulated seconds; ConfigError unless a whole number of the schedule's
    hyperperiods (a rollout starts and ends where every agent acts)."""
    physics_dt = world.physics_dt_s
    rollout_steps = round(rollout_s / physics_dt)
    hyperperiod = world.schedule.hyperperiod_steps
    if rollout_steps < 1 or abs(rollout_steps * physics_dt - rollout_s) > 1e-9 or rollout_steps % hyperperiod:
        raise ConfigError(f"rollout_s={rollout_s} must be a whole number of hyperperiods of the schedule "
                          f"({hyperperiod} physics steps = {hyperperiod * physics_dt:g} s)")
    return rollout_steps


class MultiAgentRunner:
    """One rsl-rl runner per group (its PPO, logger and checkpoints, in `<log_dir>/<group>/`); `learn` steps
    the world slot by slot, each group acting and storing its transitions at its own slots, and updates every
    group after each rollout of `cfg.rollout_s` simulated seconds."""

    def __init__(self, world: MultiAgentEnv, cfg: MultiAgentRunnerCfg, log_dir: str | None, device: str,
                 started_at: float | None = None):
        self.world = world
        self.cfg = cfg
        self.log_dir = log_dir
        grouped = [a for g in cfg.groups.values() for a in g.agents]
        missing = [a for a in world.agents if a not in grouped]
        twice = sorted({a for a in grouped if grouped.count(a) > 1})
        if missing or twice:
            raise ConfigError(f"agent groups: every agent in exactly one group; not in any: {missing}, in several: "
                              f"{twice} (groups: { {n: list(g.agents) for n, g in cfg.groups.items()} })")
        rollout_steps = rollout_physics_steps(world, cfg.rollout_s)
        self.slots_per_rollout = rollout_steps // world.schedule.hyperperiod_steps * len(world.schedule.slots)
        self.views: dict[str, GroupVecEnv] = {}
        self.runners: dict[str, CheckpointingRunner] = {}
        for name, group in cfg.groups.items():
            view = GroupVecEnv(world, name, group)
            if group.mode == "joint" and group.runner.algorithm.symmetry_cfg is not None:
                raise ConfigError(f"group '{name}': the left-right mirror is defined per robot; a 'joint' group "
                                  f"cannot use it (set agent.groups.{name}.runner.algorithm.symmetry_cfg=null)")
            group.runner.num_steps_per_env = rollout_steps // view.env.cfg.decimation
            runner_dir = None if log_dir is None else os.path.join(log_dir, name)
            self.views[name] = view
            self.runners[name] = CheckpointingRunner(view, to_rsl_rl_dict(group.runner), log_dir=runner_dir,
                                                     device=device, started_at=started_at)
        self.device = device
        self.current_learning_iteration = 0

    @heap_frozen()  # the world and the runners out of the garbage collector's whole-heap passes (agile.utils.heap)
    def learn(self, num_learning_iterations: int) -> None:
        world = self.world
        if world.slot != 0:  # a rollout starts where every group acts
            world.reset()
        obs = {g: v.get_observations().to(self.device) for g, v in self.views.items()}
        for runner in self.runners.values():
            runner.alg.train_mode()
            runner.logger.init_logging_writer()
        start_it = self.current_learning_iteration
        total_it = start_it + num_learning_iterations
        for it in range(start_it, total_it):
            start = time.time()
            with torch.inference_mode():
                for _ in range(self.slots_per_rollout):
                    acting = set(world.acting_agents)
                    actions = {}
                    for g, view in self.views.items():
                        if view.agent_names[0] in acting:
                            actions.update(view.split_actions(self.runners[g].alg.act(obs[g]).to(world.device)))
                    steps = world.step(actions)
                    for g, view in self.views.items():
                        if view.agent_names[0] not in steps:
                            continue
                        group_obs, rewards, dones, extras = view.combine(steps)
                        obs[g] = group_obs.to(self.device)
                        rewards, dones = rewards.to(self.device), dones.to(self.device)
                        self.runners[g].alg.process_env_step(obs[g], rewards, dones, extras)
                        self.runners[g].logger.process_env_step(rewards, dones, extras, None)
                for g, runner in self.runners.items():
                    runner.alg.compute_returns(obs[g])
            collect_time = time.time() - start
            for g, runner in self.runners.items():
                start = time.time()
                loss_dict = runner.alg.update()
                runner.current_learning_iteration = it
                if runner.logger.writer is not None:  # rsl-rl's report does not name the group
                    print(f"[agile] group '{g}': {', '.join(self.views[g].agent_names)}")
                runner.logger.log(it=it, start_it=start_it, total_it=total_it, collect_time=collect_time,
                                  learn_time=time.time() - start, loss_dict=loss_dict,
                                  learning_rate=runner.alg.learning_rate,
                                  action_std=runner.alg.get_policy().output_std, rnd_weight=None)
                if runner.logger.writer is not None and it % self.cfg.save_interval == 0:
                    runner.save(os.path.join(runner.logger.log_dir, f"model_{it}.pt"))
            self.current_learning_iteration = it
        for runner in self.runners.values():
            if runner.logger.writer is not None:
                runner.save(os.path.join(runner.logger.log_dir, f"model_{self.current_learning_iteration}.pt"))
                runner.logger.stop_logging_writer()
        self.current_learning_iteration += 1
