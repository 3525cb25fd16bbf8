"""One agent of a multi-agent world: its managers, and the env its terms see (its own names, rate and clock)."""

from __future__ import annotations

import torch

from agile.marl.env_cfg import AgentCfg
from agile.rl_env.env import EpisodeLog, build_managers
from agile.sim import Articulation, Scene
from agile.utils.config import ConfigError


class ScopedScene:
    """The world's scene as one agent's terms see it: `names` maps the names they use to the world's."""

    def __init__(self, scene: Scene, names: dict[str, str], where: str):
        for local, world in names.items():
            if world not in scene:
                raise ConfigError(f"{where}.scene_names['{local}']: no entity or sensor '{world}' in the scene. "
                                  f"Entities: {sorted(scene.entities)}; sensors: "
                                  f"{sorted(scene.contact_sensors) + sorted(scene.height_scanners)}")
        self.world_scene = scene
        self.names = dict(names)

    def world_name(self, name: str) -> str:
        return self.names.get(name, name)

    def __getitem__(self, name: str):
        return self.world_scene[self.world_name(name)]

    def __contains__(self, name: str) -> bool:
        return self.world_name(name) in self.world_scene

    def keys(self):
        hidden = set(self.names.values()) - set(self.names)
        return [*self.names, *(k for k in self.world_scene.keys() if k not in hidden and k not in self.names)]


class Agent:
    """An agent's MDP on the shared world, with the attributes terms read from an env (`scene`, `step_dt`,
    `episode_length_buf`, the managers, ...): the term library serves single- and multi-agent tasks alike.

    `step_dt` is the agent's control period; `episode_length_buf` counts its own steps.
    """

    def __init__(self, name: str, cfg: AgentCfg, world):
        self.name = name
        self.cfg = cfg
        self.world = world
        self.task_name = f"{world.task_name}, agent '{name}'"
        where = f"task '{world.task_name}': agents['{name}']"
        self.scene = ScopedScene(world.scene, cfg.scene_names, where)
        self.sim = world.sim
        self.device = world.device
        self.num_envs = world.num_envs
        self.env_origins = world.env_origins
        self.physics_dt_s = world.physics_dt_s
        self.step_dt = cfg.decimation * world.physics_dt_s
        """The agent's control period [s]."""
        self.max_episode_length_s = world.max_episode_length_s
        self.max_episode_length = world.max_episode_physics_steps // cfg.decimation
        """Episode length in the agent's own steps."""
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self.common_step_counter = torch.zeros((), dtype=torch.long, device=self.device)
        """The agent's steps since construction (all envs together)."""
        self.alive = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
        """(N,) False from the step a termination fires until the env resets (the robots are frozen)."""
        self.died = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        """(N,) a termination fired in this episode (a time-out ends it alive)."""
        self.log = EpisodeLog(self.device)
        self.obs_buf = None

        build_managers(self, cfg)
        self.robot_names = sorted({self.scene.world_name(t.cfg.asset_name) for t in self.action_manager.terms.values()
                                   if isinstance(self.scene[t.cfg.asset_name], Articulation)})
        """World names of the articulations its action terms drive: what freezes when it dies."""
        if not self.robot_names:
            raise ConfigError(f"{where}: its action terms drive no articulation")
