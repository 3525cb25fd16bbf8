"""Several agents at different control rates in one batched world: the env, its schedule, PettingZoo views and
RSL-RL training of agent groups (NORMAL, SHARED, JOINT)."""

from agile.marl.agent import Agent, ScopedScene
from agile.marl.env import AgentStep, MultiAgentEnv
from agile.marl.env_cfg import AgentCfg, MultiAgentEnvCfg
from agile.marl.schedule import Schedule, Slot

__all__ = ["Agent", "AgentCfg", "AgentStep", "MultiAgentEnv", "MultiAgentEnvCfg", "Schedule", "ScopedScene", "Slot"]
