"""The eight managers and the term configs a task declares."""

from agile.rl_env.managers.action_manager import ActionManager, ActionTerm, is_training_only
from agile.rl_env.managers.command_manager import CommandManager, CommandTerm
from agile.rl_env.managers.curriculum_manager import CurriculumManager
from agile.rl_env.managers.event_manager import EventManager
from agile.rl_env.managers.metrics_manager import MetricsManager, merge_episode_metrics
from agile.rl_env.managers.observation_manager import ObservationManager, TermHistory
from agile.rl_env.managers.reward_manager import RewardManager
from agile.rl_env.managers.term_cfg import (ActionTermCfg, CurrTerm, DoneTerm, EventTerm, ManagerTermBase, MetricTerm, ObsGroup,
                                            ObsTerm, RewTerm, ROBOT, SceneEntityCfg, UniformNoiseCfg, Unoise,
                                            index_list)
from agile.rl_env.managers.termination_manager import TerminationManager

__all__ = ["ActionManager", "ActionTerm", "ActionTermCfg", "CommandManager", "CommandTerm", "CurrTerm", "CurriculumManager", "DoneTerm",
           "EventManager", "EventTerm", "ManagerTermBase", "MetricTerm", "MetricsManager", "ObsGroup", "ObsTerm",
           "ObservationManager", "ROBOT", "RewTerm", "RewardManager", "SceneEntityCfg", "TermHistory", "TerminationManager",
           "UniformNoiseCfg", "Unoise", "index_list", "is_training_only", "merge_episode_metrics"]
