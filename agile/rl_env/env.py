"""ManagerBasedRLEnv: a vectorized gymnasium env whose MDP is assembled from managers."""

from __future__ import annotations

import contextlib
import math

import gymnasium as gym
import torch
import warp as wp
from tensordict import TensorDict

from agile.rl_env.capture_guard import CaptureGuard
from agile.rl_env.captured_step import CapturedStep
from agile.rl_env.managers import (ActionManager, CommandManager, CurriculumManager, EventManager, MetricsManager,
                                   ObservationManager, RewardManager, TerminationManager, merge_episode_metrics)
from agile.sim import SceneCfg, SimCfg, Simulation
from agile.utils.config import ConfigError, apply_overrides, configclass, load_entry_point
from agile.utils.output import configure_warp_output

CURRICULUM_STATE_PREFIX = "curriculum/"
"""Keys of `training_state()` that hold a curriculum term's state."""

@configclass
class ManagerBasedRLEnvCfg:
    """Top-level env config; a task file fills the scene and the manager groups."""

    num_envs: int = 4096
    decimation: int = 4
    """Physics steps per env (policy) step."""
    episode_length_s: float = 20.0
    seed: int = 42
    scene: SceneCfg = SceneCfg()
    sim: SimCfg = SimCfg()
    commands: object = None
    actions: object = None
    observations: object = None
    rewards: object = None
    terminations: object = None
    events: object = None
    curriculum: object = None
    metrics: object = None
    """Episode metrics of the task (`MetricTerm` fields: success, final height, ...) for logs and evaluation."""
    video_camera_offset_m: tuple[float, float, float] | None = None
    """Where a rendered video's camera stands from the robot it follows [m], world frame (robots face +x); None: the
    recorder's default, ahead of the robot and to its right. A task whose robot works behind something (a table)
    sets its own."""
    capture_step: bool = True
    """On CUDA, record the whole env step (term math, resets and physics) once as a CUDA graph and replay it:
    no Python runs per step. Terms must then avoid host syncs and host-to-device copies."""
    check_capture_safety: bool = False
    """Where the step is not captured (the CPU): run each step after the capture's warm-up under `CaptureGuard`,
    which raises at the first operation a CUDA graph capture refuses (a tensor made from host data, a host read of
    a device value, a data-dependent shape), naming the line: a term developed on the CPU is then safe on the GPU."""
    clip_actions: float | None = 100.0
    """The policy's raw actions are clamped to ±clip_actions before any term, observation or reward sees them (Isaac
    Lab's agent setting `clip_actions`, kept in the env so that training, evaluation, play and user code step the same
    env). The default 100 is a guard, far above what a trained policy outputs (the shipped velocity and motion-tracking
    policies stay below 6.1; StandUp-T1, whose task sets 10, reaches 31), against a diverging policy's huge
    actions: ±1e6 cost about -6.7e11 per step in the action-rate penalties. None: no clamp."""
    max_joint_speed_rad_s: float = 1000.0
    """A world whose joint speed exceeds this, or whose state is not finite, is reset and counted as unstable."""


class EpisodeLog:
    """Scalars for extras["log"], kept in one device tensor so that a captured step can update them."""

    def __init__(self, device):
        self.device = device
        self.index: dict[str, int] = {}
        self.values = torch.zeros(0, device=device)
        self._ids: dict[tuple, torch.Tensor] = {}
        self.frozen = False
        """Set once a step is captured: the graph holds `values`, so no new entry may reallocate it."""

    def write(self, entries: dict, hold_unless: torch.Tensor | None = None) -> None:
        """Store entries; with hold_unless, keep the old values where it is False (no episode finished)."""
        if not entries:
            return
        names = tuple(entries)
        new_names = [k for k in names if k not in self.index]
        if new_names:  # first step only, before any capture
            if self.frozen:
                raise RuntimeError(f"episode log entries {new_names} first written after the step was captured")
            for k in new_names:
                self.index[k] = len(self.index)
            # normal tensors even when the first such step runs under inference mode (an evaluation): an
            # inference tensor could not be written by a later step outside it (training on the same env)
            with torch.inference_mode(False):
                self.values = torch.cat((self.values, torch.zeros(len(new_names), device=self.device)))
            self._ids.clear()
        ids = self._ids.get(names)
        if ids is None:
            with torch.inference_mode(False):
                ids = self._ids[names] = torch.tensor([self.index[k] for k in names], device=self.device)
        new = torch.stack([v.float() if isinstance(v, torch.Tensor) else torch.tensor(float(v), device=self.device)
                           for v in entries.values()])
        if hold_unless is not None:
            new = torch.where(hold_unless, new, self.values[ids])
        self.values[ids] = new

    def snapshot(self) -> dict[str, torch.Tensor]:
        values = self.values.clone()
        return {k: values[i] for k, i in self.index.items()}


def default_device() -> str:
    return "cuda:0" if wp.is_cuda_available() else "cpu"


def resolve_device(device: str | None) -> str:
    device = device or default_device()
    if device.startswith("cuda") and not wp.is_cuda_available():
        raise RuntimeError(f"device '{device}' requested but no CUDA device is available; use device='cpu'")
    return device


def resolve_env_cfg(cfg, env_cfg_entry_point, num_envs: int | None, seed: int | None, overrides: list[str] | None):
    """The env config (given, or made by the registration's entry point) with gym.make's env count, seed and
    `path=value` overrides applied."""
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
    return cfg


def check_timing(cfg, task_name: str) -> None:
    """The env count, episode length and physics step have a domain; a value outside it is named at once."""
    if cfg.num_envs < 1:
        raise ConfigError(f"task '{task_name}': num_envs must be >= 1, got {cfg.num_envs}")
    if not cfg.episode_length_s > 0:
        raise ConfigError(f"task '{task_name}': episode_length_s must be positive, got {cfg.episode_length_s}")
    if not cfg.sim.physics_dt_s > 0:
        raise ConfigError(f"task '{task_name}': sim.physics_dt_s must be positive, got {cfg.sim.physics_dt_s}")
    if not cfg.max_joint_speed_rad_s > 0:  # else every step of every env would count as unstable
        raise ConfigError(f"task '{task_name}': max_joint_speed_rad_s must be positive, "
                          f"got {cfg.max_joint_speed_rad_s}")


def build_managers(env, cfg) -> None:
    """The managers of an MDP as attributes of `env` (a single-agent env, or one agent of a multi-agent world),
    built in the order their terms need: commands and actions exist before the observation terms that read them."""
    env.event_manager = EventManager(cfg.events, env)
    env.command_manager = CommandManager(cfg.commands, env)
    env.action_manager = ActionManager(cfg.actions, env, clip_actions=cfg.clip_actions)
    env.observation_manager = ObservationManager(cfg.observations, env)
    env.termination_manager = TerminationManager(cfg.terminations, env)
    env.reward_manager = RewardManager(cfg.rewards, env)
    env.curriculum_manager = CurriculumManager(cfg.curriculum, env)
    # after the terminations: an episode-end metric reads how the episode ended
    env.metrics_manager = MetricsManager(getattr(cfg, "metrics", None), env)
    if not env.termination_manager.active_terms:
        raise ConfigError(f"task '{env.task_name}': no termination terms (at least a time_out is needed)")
    env.last_episode_metrics = merge_episode_metrics(env)
    """(N,) each env's most recently ended episode's metrics: the command terms' ("<term>/<name>") and the metric
    terms' ("<name>"), as they stood at the end; written in place by each step (what eval.py reads)."""


class ManagerBasedRLEnv(gym.Env):
    """Vectorized env: every tensor has the env count as its first dimension; resets happen inside step().

    `env_cfg_entry_point` and `rsl_rl_cfg_entry_point` come from the gymnasium registration; the second is
    read by the scripts through `agile.tasks.load_cfgs`, not by the env.
    """

    metadata = {"render_modes": [None]}
    is_vector_env = True

    def __init__(self, cfg: ManagerBasedRLEnvCfg | None = None, *, env_cfg_entry_point=None,
                 rsl_rl_cfg_entry_point=None, task_name: str | None = None, num_envs: int | None = None,
                 device: str | None = None, seed: int | None = None, overrides: list[str] | None = None,
                 render_mode=None, **extra_entry_points):
        cfg = resolve_env_cfg(cfg, env_cfg_entry_point, num_envs, seed, overrides)
        self.cfg = cfg
        self.task_name = task_name or type(cfg).__name__
        self.render_mode = render_mode
        configure_warp_output()  # quiet unless AGILE_VERBOSE=1
        device = resolve_device(device)
        check_timing(cfg, self.task_name)
        if not (isinstance(cfg.decimation, int) and cfg.decimation >= 1):
            raise ConfigError(f"task '{self.task_name}': decimation must be a whole number >= 1 (physics steps per "
                              f"env step), got {cfg.decimation!r}")
        torch.manual_seed(cfg.seed)

        self.num_envs = cfg.num_envs
        self.physics_dt_s = cfg.sim.physics_dt_s
        self.step_dt = cfg.decimation * cfg.sim.physics_dt_s
        self.max_episode_length_s = cfg.episode_length_s
        self.max_episode_length = math.ceil(cfg.episode_length_s / self.step_dt)

        try:
            self.sim = Simulation(cfg.sim, cfg.scene, cfg.num_envs, device, self.step_dt)
        except ConfigError as err:
            raise ConfigError(f"task '{self.task_name}': {err}") from None
        self.device = self.sim.device
        self.common_step_counter = torch.zeros((), dtype=torch.long, device=self.device)
        """Env steps since construction (all envs together), as a device tensor."""
        self.scene = self.sim.scene
        """Entities and sensors by name: `env.scene["robot"]`, `env.scene["contact_forces"]`."""
        self.env_origins = self.sim.env_origins
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self.reset_buf = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self.sim_unstable = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        self._all_envs = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        self._log = EpisodeLog(self.device)
        self._captured_step = CapturedStep(self.sim, self._step)
        self._uncaptured_steps = 0  # the steps before a capture would be recorded are not checked (its warm-up)

        build_managers(self, cfg)

        self.event_manager.apply("startup", self._all_envs)
        self.single_action_space = gym.spaces.Box(-math.inf, math.inf, (self.action_manager.total_action_dim,))
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.single_observation_space = self.observation_manager.space()
        self.observation_space = self.observation_manager.space(batch=self.num_envs)
        self._reset_envs(self._all_envs)
        self.obs_buf = self.observation_manager.compute()
        self.extras: dict = {}
        # terms that need the built env make what they need now (a stand-up task's fallen-state dataset, which
        # resets the env from it): gym.make builds exactly what training runs
        self.event_manager.prepare_terms()

    # -- gymnasium API ---------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[TensorDict, dict]:
        if seed is not None:
            torch.manual_seed(seed)
        self.episode_length_buf.zero_()
        self._reset_envs(self._all_envs)
        self.obs_buf = self.observation_manager.compute()
        return self.obs_buf, {"log": self._log.snapshot()}

    @property
    def step_is_captured(self) -> bool:
        return self.cfg.capture_step and self.sim.wp_device.is_cuda and self.sim.use_graph

    def step(self, action: torch.Tensor):
        """Apply an action for `decimation` physics steps; finished envs are reset before the obs are computed.

        Returns (obs, reward, terminated, truncated, extras); extras["time_outs"] equals truncated and
        extras["log"] holds episode statistics of the envs that finished most recently.
        """
        action = action.to(self.device)
        if not self.step_is_captured:
            self._uncaptured_steps += 1
            check = self.cfg.check_capture_safety and self._uncaptured_steps > CapturedStep.WARMUP_CALLS
            with CaptureGuard() if check else contextlib.nullcontext():
                obs, reward, terminated, time_outs = self._step(action)
        else:
            obs, reward, terminated, time_outs = self._captured_step(action)
            self._log.frozen = self._captured_step.graph is not None
        self.obs_buf = obs
        self.extras = {"time_outs": time_outs, "log": self._log.snapshot()}
        return obs, reward, terminated, time_outs, self.extras

    def _step(self, action: torch.Tensor, physics_graph: bool = True):
        self.action_manager.process_action(action)
        self.action_manager.apply_action()
        self.sim.step(self.cfg.decimation, graph=physics_graph)
        self.episode_length_buf += 1
        self.common_step_counter += 1
        self.scene.update_after_physics()
        torch.logical_not(self.scene.state_is_valid(self.cfg.max_joint_speed_rad_s), out=self.sim_unstable)

        invalid = self.sim_unstable | self.action_manager.invalid_action
        self.reset_buf[:] = self.termination_manager.compute() | invalid
        terminated = self.termination_manager.terminated | invalid
        time_outs = self.termination_manager.time_outs & ~invalid
        reward = self.reward_manager.compute(self.step_dt, active=~self.sim_unstable)
        self.command_manager.update_metrics()  # of the state the rewards judged, before resets replace it
        self.metrics_manager.update_metrics()

        self._log.write(self.curriculum_manager.compute(self.reset_buf))
        self._reset_envs(self.reset_buf)
        self.command_manager.compute(self.step_dt)
        self.event_manager.apply("interval", dt=self.step_dt)
        obs = self.observation_manager.compute()
        return obs, reward, terminated, time_outs

    def simulate(self, action: torch.Tensor, num_steps: int) -> None:
        """Run `num_steps` env steps of `action` with the actions, actuators, physics and sensors only: no
        terminations, rewards, resets, commands, events or curricula, and episode clocks stand still. For collecting
        states before learning (the fallen-state dataset: robots dropped and left to settle wherever they land)."""
        action = action.to(self.device)
        for _ in range(num_steps):
            self.action_manager.process_action(action)
            self.action_manager.apply_action()
            self.sim.step(self.cfg.decimation)
            self.scene.update_after_physics()

    def close(self):
        pass

    # -- what training depends on, saved with each checkpoint ---------------------------------------

    def training_state(self) -> dict[str, torch.Tensor]:
        """The env state a resumed training needs (CPU tensors): the step counter, which drives the reward-weight
        ramps, each env's terrain level, and the adaptive curricula's state ("curriculum/<term>.<attr>", e.g. the
        stand-up lift's strength). Observation histories and episodes start afresh."""
        state = {"common_step_counter": self.common_step_counter.detach().cpu().clone()}
        if self.sim.terrain is not None:
            state["terrain_levels"] = self.sim.terrain_levels.detach().cpu().clone()
        for key, value in self.curriculum_manager.training_state().items():
            state[f"{CURRICULUM_STATE_PREFIX}{key}"] = value
        return state

    def load_training_state(self, state: dict[str, torch.Tensor]) -> None:
        """Restore `training_state()` and reset every env (robots spawn at their restored terrain levels). A state of
        another env count (a training moved to more or fewer envs, or GPUs) is spread over this env's: each env takes
        the terrain level and the curriculum counts of one of the state's envs on its own terrain column."""
        self.common_step_counter.fill_(int(state["common_step_counter"]))
        levels = state.get("terrain_levels")
        source_envs = None
        if levels is not None and self.sim.terrain is not None:
            if levels.shape[0] != self.num_envs:
                source_envs = self.sim.same_column_envs(levels.shape[0]).cpu()
                print(f"[agile] the checkpoint's training state is of {levels.shape[0]} envs, this env has "
                      f"{self.num_envs}: each env takes the terrain level and curriculum counts of one of the "
                      f"checkpoint's envs on its terrain column")
                levels = levels[source_envs]
            self.sim.set_terrain_levels(levels.to(self.device))
        curriculum = {key[len(CURRICULUM_STATE_PREFIX):]: value for key, value in state.items()
                      if key.startswith(CURRICULUM_STATE_PREFIX)}
        resized = None if source_envs is None else (state["terrain_levels"].shape[0], source_envs)
        missing = self.curriculum_manager.load_training_state(curriculum, resized=resized)
        if missing:
            print(f"[agile] the checkpoint holds no state for {missing}: those curriculum terms start afresh")
        self.reset()

    # -- resets ----------------------------------------------------------------------------------

    def _reset_envs(self, env_mask: torch.Tensor) -> None:
        """Reset the envs where env_mask is True; masked writes only, no host synchronisation."""
        log = {}
        any_reset = env_mask.any()
        count = env_mask.sum().clamp(min=1)
        log["Episode_Termination/sim_unstable"] = (self.sim_unstable & env_mask).sum() / count
        log["Episode_Termination/invalid_action"] = (self.action_manager.invalid_action & env_mask).sum() / count
        log["Episode/length_s"] = torch.where(env_mask, self.episode_length_buf, 0).sum() / count * self.step_dt
        log.update(self.sim.capacity.log())
        for manager in (self.reward_manager, self.termination_manager):
            log.update(manager.reset(env_mask))
        log.update(self.command_manager.finish_episodes(env_mask))  # the final state is still there
        log.update(self.metrics_manager.finish_episodes(env_mask))
        # logs describe finished episodes: keep the last values while no env finishes
        self._log.write(log, hold_unless=any_reset)

        self.sim.reset_worlds(env_mask)
        self.scene.reset_to_default(env_mask)
        self.event_manager.apply("reset", env_mask)
        self.sim.forward(env_mask)
        self.scene.update()

        for manager in (self.action_manager, self.command_manager, self.metrics_manager, self.observation_manager,
                        self.event_manager):
            manager.reset(env_mask)
        self.episode_length_buf.masked_fill_(env_mask, 0)
