"""MultiAgentEnv: several agents, each with its own control rate and MDP, in one batched world, stepped
synchronously slot by slot (no threads), each slot's step capturable as one CUDA graph."""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import gymnasium as gym
import torch
from tensordict import TensorDict

from agile.marl.agent import Agent
from agile.marl.env_cfg import AgentCfg, MultiAgentEnvCfg
from agile.marl.schedule import Schedule
from agile.rl_env.captured_step import CapturedStep
from agile.rl_env.env import check_timing, resolve_device, resolve_env_cfg
from agile.utils.output import configure_warp_output
from agile.rl_env.managers import CurriculumManager, EventManager
from agile.sim import Simulation
from agile.utils.config import ConfigError


class AgentStep(NamedTuple):
    """What one agent receives when its control period ends (each value batched over envs)."""

    obs: TensorDict
    """Its next observation; zeros where its robots are dead (frozen) and the env has not reset yet."""
    reward: torch.Tensor
    """(N,) reward over its period; 0 where it is dead."""
    terminated: torch.Tensor
    """(N,) its termination fired this period, or (once) the env of its dead robots reset."""
    truncated: torch.Tensor
    """(N,) the episode's time ran out."""
    alive: torch.Tensor
    """(N,) its robots were alive during this period (False: frozen, waiting for the env to reset)."""
    extras: dict


class MultiAgentEnv(gym.Env):
    """Agents act at the slots of their `Schedule`; `step(actions)` takes the actions of the agents acting now
    (`acting_agents`), runs the physics to the next slot and returns an `AgentStep` for each agent acting there.

    Soft death: an agent whose termination fires in an env has its robots frozen in place, its rewards and
    observations masked, while the other agents play on; the env resets when no agent is left alive in it
    (or the time runs out), always at the start of a hyperperiod, where every agent's period ends.
    """

    metadata = {"render_modes": [None]}
    is_vector_env = True

    def __init__(self, cfg: MultiAgentEnvCfg | None = None, *, env_cfg_entry_point=None, task_name: str | None = None,
                 num_envs: int | None = None, device: str | None = None, seed: int | None = None,
                 overrides: list[str] | None = None, render_mode=None, **registration_kwargs):
        cfg = resolve_env_cfg(cfg, env_cfg_entry_point, num_envs, seed, overrides)
        self.cfg = cfg
        self.task_name = task_name or type(cfg).__name__
        self.render_mode = render_mode
        configure_warp_output()  # quiet unless AGILE_VERBOSE=1
        where = f"task '{self.task_name}'"
        check_timing(cfg, self.task_name)
        if not cfg.agents:
            raise ConfigError(f"{where}: no agents (MultiAgentEnvCfg.agents is empty)")
        for name, agent_cfg in cfg.agents.items():
            if not isinstance(agent_cfg, AgentCfg):
                raise ConfigError(f"{where}: agents['{name}'] is a {type(agent_cfg).__name__}, not an AgentCfg")
        try:
            self.schedule = Schedule({name: a.decimation for name, a in cfg.agents.items()})
        except ValueError as err:
            raise ConfigError(f"{where}: {err}") from None
        torch.manual_seed(cfg.seed)

        self.num_envs = cfg.num_envs
        self.physics_dt_s = cfg.sim.physics_dt_s
        self.tick_dt_s = self.schedule.tick_steps * self.physics_dt_s
        hyperperiods = math.ceil(cfg.episode_length_s / (self.schedule.hyperperiod_steps * self.physics_dt_s) - 1e-9)
        self.max_episode_physics_steps = max(hyperperiods, 1) * self.schedule.hyperperiod_steps
        self.max_episode_length_s = self.max_episode_physics_steps * self.physics_dt_s
        device = resolve_device(device)
        try:
            self.sim = Simulation(cfg.sim, cfg.scene, cfg.num_envs, device, self.tick_dt_s)
        except ConfigError as err:
            raise ConfigError(f"{where}: {err}") from None
        self.device = self.sim.device
        self.scene = self.sim.scene
        self.env_origins = self.sim.env_origins
        self.common_step_counter = torch.zeros((), dtype=torch.long, device=self.device)
        """Ticks since construction, as a device tensor."""
        self.sim_unstable = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        """(N,) the world blew up since its last reset: every agent's episode ends there."""

        self.event_manager = EventManager(cfg.events, self)
        self.agents: dict[str, Agent] = {name: Agent(name, a, self) for name, a in cfg.agents.items()}
        self.curriculum_manager = CurriculumManager(cfg.curriculum, self)
        self.possible_agents = list(self.agents)
        self._frozen_root_pose = {r: self.scene[r].root_pose_w.clone() for a in self.agents.values()
                                  for r in a.robot_names}
        self._frozen_joint_pos = {r: self.scene[r].joint_pos.clone() for r in self._frozen_root_pose}

        self.event_manager.apply("startup", torch.ones(self.num_envs, dtype=torch.bool, device=self.device))
        for agent in self.agents.values():
            agent.event_manager.apply("startup", torch.ones(self.num_envs, dtype=torch.bool, device=self.device))
        self.single_action_spaces = {n: gym.spaces.Box(-math.inf, math.inf, (a.action_manager.total_action_dim,))
                                     for n, a in self.agents.items()}
        self.single_observation_spaces = {n: a.observation_manager.space() for n, a in self.agents.items()}
        self.mean_slot_dt_s = self.schedule.hyperperiod_steps * self.physics_dt_s / len(self.schedule.slots)
        """Simulated time per `step`, on average over a hyperperiod (a video's frame interval)."""
        self.slot = 0
        """Index of the current slot in `schedule.slots`: whose turn it is."""
        self._captured_slots = [CapturedStep(self.sim, functools.partial(self._slot_step, i))
                                for i in range(len(self.schedule.slots))]
        self.reset()

    # -- API -------------------------------------------------------------------------------------------

    @property
    def acting_agents(self) -> tuple[str, ...]:
        """The agents whose actions the next `step` takes."""
        return self.schedule.slots[self.slot].agents

    @property
    def step_is_captured(self) -> bool:
        return self.cfg.capture_step and self.sim.wp_device.is_cuda and self.sim.use_graph

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Reset every env; the schedule restarts (every agent acts next). Returns ({agent: obs}, {agent: info})."""
        if seed is not None:
            torch.manual_seed(seed)
        self.slot = 0
        self._reset_envs(torch.ones(self.num_envs, dtype=torch.bool, device=self.device))
        for agent in self.agents.values():
            agent.obs_buf = agent.observation_manager.compute()
        return ({n: a.obs_buf for n, a in self.agents.items()},
                {n: {"log": a.log.snapshot()} for n, a in self.agents.items()})

    def check_observation_groups(self, *groups: str) -> None:
        """Raise ConfigError unless every agent has each of `groups` (a trainer's actor and critic inputs)."""
        for name, agent in self.agents.items():
            missing = [g for g in groups if g not in agent.observation_manager.group_dims]
            if missing:
                raise ConfigError(f"agent '{name}': no observation group {missing}; groups: "
                                  f"{list(agent.observation_manager.group_dims)}")

    def step(self, actions: dict[str, torch.Tensor]) -> dict[str, AgentStep]:
        """Apply the acting agents' actions and run to the next slot; an `AgentStep` for each agent acting there."""
        acting = self.acting_agents
        if set(actions) != set(acting):
            raise ValueError(f"step needs the actions of the agents acting now, {list(acting)}; got {sorted(actions)}")
        inputs = []
        for name in acting:
            action = actions[name].to(self.device)
            expected = (self.num_envs, self.agents[name].action_manager.total_action_dim)
            if tuple(action.shape) != expected:
                raise ValueError(f"agent '{name}': action shape {tuple(action.shape)} != expected {expected}")
            inputs.append(action)
        if self.step_is_captured:
            step = self._captured_slots[self.slot]
            outputs = step(*inputs)
            for agent in self.agents.values():
                agent.log.frozen = step.graph is not None or agent.log.frozen
        else:
            outputs = self._slot_step(self.slot, *inputs)
        self.slot = (self.slot + 1) % len(self.schedule.slots)
        results = {}
        for name, (obs, reward, terminated, truncated, alive) in outputs.items():
            agent = self.agents[name]
            agent.obs_buf = obs
            results[name] = AgentStep(obs, reward, terminated, truncated, alive,
                                      {"time_outs": truncated, "log": agent.log.snapshot()})
        return results

    def close(self):
        pass

    # -- one slot ----------------------------------------------------------------------------------------

    def _slot_step(self, slot_index: int, *actions: torch.Tensor, physics_graph: bool = True) -> dict:
        """Act, run the ticks to the next slot, end the periods of the agents acting there, reset finished envs at
        the end of a hyperperiod, and observe. No host synchronisation: the whole slot can be one graph."""
        slots = self.schedule.slots
        for name, action in zip(slots[slot_index].agents, actions):
            manager = self.agents[name].action_manager
            manager.process_action(action)
            manager.apply_action()
        for _ in range(slots[slot_index].ticks_to_next):
            self.sim.step(self.schedule.tick_steps, graph=physics_graph)
            self._hold_dead_robots()
            self.scene.update_after_physics()
            self.sim_unstable |= ~self.scene.state_is_valid(self.cfg.max_joint_speed_rad_s)
            self.common_step_counter += 1
            self.event_manager.apply("interval", dt=self.tick_dt_s)
            for agent in self.agents.values():
                agent.event_manager.apply("interval", dt=self.tick_dt_s)

        next_index = (slot_index + 1) % len(slots)
        ended = {name: self._end_period(self.agents[name]) for name in slots[next_index].agents}
        if next_index == 0:  # the hyperperiod ends: every agent's period ends here, envs may reset
            env_done = torch.stack([~a.alive for a in self.agents.values()]).all(dim=0)
            for name, (reward, terminated, truncated, was_alive) in ended.items():
                # a dead agent's frozen wait ends with its env's reset: say so once, so no return runs across it
                terminated |= env_done & ~was_alive
            self.curriculum_manager.compute(env_done)
            for agent in self.agents.values():
                agent.log.write(agent.curriculum_manager.compute(env_done))
            self._reset_envs(env_done)
        outputs = {}
        for name, (reward, terminated, truncated, was_alive) in ended.items():
            agent = self.agents[name]
            agent.command_manager.compute(agent.step_dt)
            obs = agent.observation_manager.compute()
            alive = agent.alive
            obs = obs.apply(lambda t: t * alive.view(-1, *([1] * (t.dim() - 1))))
            outputs[name] = (obs, reward, terminated, truncated, was_alive)
        return outputs

    def _end_period(self, agent: Agent):
        """Terminations and reward of an agent whose period ends; a termination freezes its robots."""
        agent.episode_length_buf += 1
        agent.common_step_counter += 1
        agent.termination_manager.compute()
        was_alive = agent.alive.clone()
        # a non-finite action (replaced by 0 when processed) ends the agent like a termination
        terminated = (agent.termination_manager.terminated | self.sim_unstable |
                      agent.action_manager.invalid_action) & was_alive
        truncated = agent.termination_manager.time_outs & was_alive & ~terminated
        reward = agent.reward_manager.compute(agent.step_dt, active=was_alive & ~self.sim_unstable)
        agent.command_manager.update_metrics()
        agent.metrics_manager.update_metrics()
        mask = terminated.unsqueeze(-1)
        for robot_name in agent.robot_names:
            robot = self.scene[robot_name]
            self._frozen_root_pose[robot_name].copy_(torch.where(mask, robot.root_pose_w,
                                                                 self._frozen_root_pose[robot_name]))
            self._frozen_joint_pos[robot_name].copy_(torch.where(mask, robot.joint_pos,
                                                                 self._frozen_joint_pos[robot_name]))
        agent.alive &= ~(terminated | truncated)
        agent.died |= terminated
        return reward, terminated, truncated, was_alive

    def _hold_dead_robots(self) -> None:
        """Put the robots of dead agents back where they died, at rest (masked writes, then forward kinematics)."""
        any_dead = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        for agent in self.agents.values():
            dead = ~agent.alive
            any_dead |= dead
            for robot_name in agent.robot_names:
                robot = self.scene[robot_name]
                robot.write_root_state(self._frozen_root_pose[robot_name], torch.zeros_like(robot.root_com_vel_w),
                                       dead)
                robot.write_joint_state(self._frozen_joint_pos[robot_name], torch.zeros_like(robot.joint_vel), dead)
        self.sim.forward(any_dead)

    # -- resets ------------------------------------------------------------------------------------------

    def _reset_envs(self, env_mask: torch.Tensor) -> None:
        """Reset the envs where env_mask is True, for every agent; masked writes only, no host synchronisation."""
        any_reset = env_mask.any()
        count = env_mask.sum().clamp(min=1)
        for agent in self.agents.values():
            log = {"Episode/length_s": torch.where(env_mask, agent.episode_length_buf, 0).sum() / count * agent.step_dt,
                   "Episode/died": (agent.died & env_mask).sum() / count,
                   "Episode_Termination/sim_unstable": (self.sim_unstable & env_mask).sum() / count,
                   "Episode_Termination/invalid_action": (agent.action_manager.invalid_action & env_mask).sum() / count,
                   **self.sim.capacity.log()}
            for manager in (agent.reward_manager, agent.termination_manager):
                log.update(manager.reset(env_mask))
            log.update(agent.command_manager.finish_episodes(env_mask))
            log.update(agent.metrics_manager.finish_episodes(env_mask))
            agent.log.write(log, hold_unless=any_reset)

        self.sim.reset_worlds(env_mask)
        self.scene.reset_to_default(env_mask)
        self.event_manager.apply("reset", env_mask)
        for agent in self.agents.values():
            agent.event_manager.apply("reset", env_mask)
        self.sim.forward(env_mask)
        self.scene.update()

        self.event_manager.reset(env_mask)
        for agent in self.agents.values():
            for manager in (agent.action_manager, agent.command_manager, agent.metrics_manager,
                            agent.observation_manager, agent.event_manager):
                manager.reset(env_mask)
            agent.episode_length_buf.masked_fill_(env_mask, 0)
            agent.alive |= env_mask
            agent.died &= ~env_mask
        self.sim_unstable &= ~env_mask
