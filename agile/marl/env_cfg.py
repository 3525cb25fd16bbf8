"""Configs of a multi-agent world: the shared scene, and per agent a control period and an MDP."""

from __future__ import annotations

from agile.sim import SceneCfg, SimCfg
from agile.utils.config import configclass


@configclass
class AgentCfg:
    """One agent: robots of the shared scene driven at one control rate, with its own MDP written with the
    single-agent managers and term library."""

    decimation: int = 4
    """Physics steps per action (its control period): 4 at 200 Hz physics is a 50 Hz policy, 8 is 25 Hz."""
    scene_names: dict = {}
    """Names this agent's terms use -> entities and sensors of the world scene, e.g. {"robot": "g1",
    "contact_forces": "g1_contact_forces"}: a single-robot MDP written for "robot" drives the G1 unchanged.
    Names not listed are the world's own (a term can still read the other robot by its name)."""
    clip_actions: float | None = 100.0
    """The policy's raw actions are clamped to ±clip_actions before any term, observation or reward sees them (Isaac
    Lab's agent setting `clip_actions`, kept in the env so that training, evaluation, play and user code step the same
    env). As `ManagerBasedRLEnvCfg.clip_actions`, per agent."""
    commands: object = None
    actions: object = None
    observations: object = None
    rewards: object = None
    terminations: object = None
    """Per agent; a termination that fires freezes the agent's robots until the whole env resets (soft death).
    At least a time_out term."""
    events: object = None
    """Events of the agent's robots (its randomisation, resets, pushes), with its scene names."""
    curriculum: object = None
    metrics: object = None
    """The agent's episode metrics (`MetricTerm` fields), logged as Metrics/<name> in its log."""


@configclass
class MultiAgentEnvCfg:
    """A world of `num_envs` envs, each holding every agent's robots; events and curriculum of the whole world."""

    num_envs: int = 4096
    episode_length_s: float = 20.0
    """Rounded up to whole hyperperiods of the schedule: every agent's episode ends at the same physics step."""
    seed: int = 42
    scene: SceneCfg = SceneCfg()
    sim: SimCfg = SimCfg()
    agents: dict = {}
    """{agent name: AgentCfg}, in the order they act within a slot."""
    events: object = None
    curriculum: object = None
    capture_step: bool = True
    """On CUDA, record each slot's step (term math, resets and physics) as a CUDA graph and replay it."""
    max_joint_speed_rad_s: float = 1000.0
    """A world whose joint speed exceeds this, or whose state is not finite, ends for every agent."""
