"""ManagerBasedRLEnv: a vectorized gymnasium env whose MDP is assembled from managers."""

from __future__ import annotations

import math

import gymnasium as gym
import torch
import warp as wp
from tensordict import TensorDict

from agile.rl_env.managers import (ActionManager, CommandManager, CurriculumManager, EventManager, ObservationManager,
                                   RewardManager, TerminationManager)
from agile.sim import RobotCfg, SimCfg, Simulation
from agile.utils.config import ConfigError, apply_overrides, configclass, load_entry_point


@configclass
class ManagerBasedRLEnvCfg:
    """Top-level env config; a task file fills the manager groups."""

    num_envs: int = 4096
    decimation: int = 4
    """Physics steps per env (policy) step."""
    episode_length_s: float = 20.0
    seed: int = 42
    sim: SimCfg = SimCfg()
    robot: RobotCfg = RobotCfg()
    commands: object = None
    actions: object = None
    observations: object = None
    rewards: object = None
    terminations: object = None
    events: object = None
    curriculum: object = None
    max_joint_speed_rad_s: float = 1000.0
    """A world whose joint speed exceeds this, or whose state is not finite, is reset and counted as unstable."""


def default_device() -> str:
    return "cuda:0" if wp.is_cuda_available() else "cpu"


class ManagerBasedRLEnv(gym.Env):
    """Vectorized env: every tensor has the env count as its first dimension; resets happen inside step()."""

    metadata = {"render_modes": [None]}
    is_vector_env = True

    def __init__(self, cfg: ManagerBasedRLEnvCfg | None = None, *, env_cfg_entry_point=None,
                 rsl_rl_cfg_entry_point=None, task_name: str | None = None, num_envs: int | None = None,
                 device: str | None = None, seed: int | None = None, overrides: list[str] | None = None,
                 render_mode=None, **extra_entry_points):
        if cfg is None:
            if env_cfg_entry_point is None:
                raise ValueError("pass an env cfg or env_cfg_entry_point")
            cfg = load_entry_point(env_cfg_entry_point)()
        if num_envs is not None:
            cfg.num_envs = int(num_envs)
        if seed is not None:
            cfg.seed = int(seed)
        if overrides:
            apply_overrides({"env": cfg}, [o if o.startswith("env.") else f"env.{o}" for o in overrides])
        self.cfg = cfg
        self.task_name = task_name or type(cfg).__name__
        self.agent_cfg_entry_point = rsl_rl_cfg_entry_point
        self.render_mode = render_mode
        device = device or default_device()
        if device.startswith("cuda") and not wp.is_cuda_available():
            raise RuntimeError(f"device '{device}' requested but no CUDA device is available; use device='cpu'")
        torch.manual_seed(cfg.seed)

        self.num_envs = cfg.num_envs
        self.physics_dt_s = cfg.sim.physics_dt_s
        self.step_dt = cfg.decimation * cfg.sim.physics_dt_s
        self.max_episode_length_s = cfg.episode_length_s
        self.max_episode_length = math.ceil(cfg.episode_length_s / self.step_dt)
        self.common_step_counter = 0

        self.sim = Simulation(cfg.sim, cfg.robot, cfg.num_envs, device, self.step_dt)
        self.device = self.sim.device
        self.robot = self.sim.robot
        self.scene = {"robot": self.robot}
        self.env_origins = self.sim.env_origins
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self.reset_buf = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self.sim_unstable = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        self._all_envs = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self._log: dict[str, torch.Tensor] = {}

        # order matters: commands and actions exist before the observation terms that read them
        self.event_manager = EventManager(cfg.events, self)
        self.command_manager = CommandManager(cfg.commands, self)
        self.action_manager = ActionManager(cfg.actions, self)
        self.observation_manager = ObservationManager(cfg.observations, self)
        self.termination_manager = TerminationManager(cfg.terminations, self)
        self.reward_manager = RewardManager(cfg.rewards, self)
        self.curriculum_manager = CurriculumManager(cfg.curriculum, self)
        if not self.termination_manager.active_terms:
            raise ConfigError(f"task '{self.task_name}': no termination terms (at least a time_out is needed)")

        self.event_manager.apply("startup", self._all_envs)
        self.single_action_space = gym.spaces.Box(-math.inf, math.inf, (self.action_manager.total_action_dim,))
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gym.spaces.Dict({
            g: gym.spaces.Box(-math.inf, math.inf, (self.num_envs, d))
            for g, d in self.observation_manager.group_dims.items()})
        self._reset_envs(self._all_envs)
        self.obs_buf = self.observation_manager.compute()
        self.extras: dict = {}

    # -- gymnasium API ---------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[TensorDict, dict]:
        if seed is not None:
            torch.manual_seed(seed)
        self.episode_length_buf.zero_()
        self._reset_envs(self._all_envs)
        self.obs_buf = self.observation_manager.compute()
        return self.obs_buf, {"log": dict(self._log)}

    def step(self, action: torch.Tensor):
        """Apply an action for `decimation` physics steps; finished envs are reset before the obs are computed."""
        self.action_manager.process_action(action.to(self.device))
        self.action_manager.apply_action()
        self.sim.step(self.cfg.decimation)
        self.episode_length_buf += 1
        self.common_step_counter += 1
        self.robot.update()
        self.robot.update_joint_acc()
        self.robot.compute_pd_torque()

        robot = self.robot
        state_ok = torch.isfinite(robot.root_pose_w).all(-1) & torch.isfinite(robot.root_com_vel_w).all(-1) & \
            torch.isfinite(robot.joint_pos).all(-1) & (robot.joint_vel.abs() <= self.cfg.max_joint_speed_rad_s).all(-1)
        torch.logical_not(state_ok, out=self.sim_unstable)

        self.reset_buf[:] = self.termination_manager.compute() | self.sim_unstable
        terminated = self.termination_manager.terminated | self.sim_unstable
        time_outs = self.termination_manager.time_outs & ~self.sim_unstable
        reward = torch.where(self.sim_unstable, 0.0, self.reward_manager.compute(self.step_dt))
        reward = torch.nan_to_num(reward, nan=0.0, posinf=0.0, neginf=0.0)

        self._log.update(self.curriculum_manager.compute(self.reset_buf))
        self._reset_envs(self.reset_buf)
        self.command_manager.compute(self.step_dt)
        self.event_manager.apply("interval", dt=self.step_dt)
        self.obs_buf = self.observation_manager.compute()
        self.extras = {"time_outs": time_outs.clone(), "log": dict(self._log)}
        return self.obs_buf, reward.clone(), terminated.clone(), time_outs.clone(), self.extras

    def close(self):
        pass

    # -- resets ----------------------------------------------------------------------------------

    def _reset_envs(self, env_mask: torch.Tensor) -> None:
        """Reset the envs where env_mask is True; masked writes only, no host synchronisation."""
        log = {}
        any_reset = env_mask.any()
        count = env_mask.sum().clamp(min=1)
        log["Episode_Termination/sim_unstable"] = (self.sim_unstable & env_mask).sum() / count
        log["Episode/length_s"] = torch.where(env_mask, self.episode_length_buf, 0).sum() / count * self.step_dt
        for manager in (self.reward_manager, self.termination_manager):
            log.update(manager.reset(env_mask))
        # logs describe finished episodes: keep the last value while no env finishes
        for key, value in log.items():
            held = self._log.get(key)
            self._log[key] = value if held is None else torch.where(any_reset, value, held)

        self.sim.reset_worlds(env_mask)
        robot = self.robot
        default_pose = robot.default_root_pose.clone()
        default_pose[:, :3] += self.env_origins
        robot.write_root_state(default_pose, torch.zeros_like(robot.root_com_vel_w), env_mask)
        robot.write_joint_state(robot.default_joint_pos, robot.default_joint_vel, env_mask)
        self.event_manager.apply("reset", env_mask)
        self.sim.forward(env_mask)
        robot.update()

        for manager in (self.action_manager, self.command_manager, self.observation_manager, self.event_manager):
            manager.reset(env_mask)
        self.episode_length_buf.masked_fill_(env_mask, 0)
