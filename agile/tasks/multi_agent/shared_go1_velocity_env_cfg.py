"""Shared-Go1-Velocity-v0: two Unitree Go1s walk side by side in every env, each following its own velocity command,
both driven by one policy (a `shared` agent group: their samples batched into one PPO), without touching each other.

The multi-robot system's SHARED example (two Go2s through one policy), with the Go1. Each agent's MDP is
Velocity-Flat-Go1-v0's (commands, actions, observations, rewards, terminations, events with its domain randomisation)
term for term, written for "robot" and mapped onto its Go1 by `scene_names`; added: where the other Go1 is (its
planar position and velocity in this one's heading frame, to the policy and the critic: a robot blind to the other
could not keep clear of it), the penalty for coming within 0.8 m of it and the one for touching it; and the trunk
contact that ends an episode is the ground's alone (a touch of the other robot is penalised, not a fall). Resets stay
within ±0.3 m of the spawn points, so the robots never start inside each other. The single task's curriculum (the
action-rate weights' ramps) does not run here: the agents keep its initial weights.
"""

from __future__ import annotations

import dataclasses

from agile.assets.unitree_go1 import BASE_BODY, go1_robot_cfg
from agile.marl import AgentCfg, MultiAgentEnvCfg
from agile.rl_env.managers import ObsTerm
from agile.sim import ContactSensorCfg, SceneCfg
from agile.tasks.multi_agent.velocity_agents import (keep_clear_penalty, other_robot_obs, touch_penalty,
                                                    trunk_on_ground_sensors, trunk_on_ground_terminations,
                                                    velocity_scene_names)
from agile.tasks.velocity.go1 import velocity_env_cfg as go1_task
from agile.tasks.velocity.velocity_common import (BASE_HEIGHT_SENSOR, CONTACT_SENSOR, VelocityCriticObsCfg,
                                                  VelocityPolicyObsCfg, uniform_root_reset, velocity_sim_cfg)
from agile.utils.config import configclass

ROBOTS = ("go1_a", "go1_b")
SPAWN_OFFSET_Y_M = 0.75
"""Each robot spawns this far from the env origin, go1_a to the right (-y), go1_b to the left (a Go1 is 0.3 m wide)."""
RESET_XY_RANGE_M = 0.3
TOUCH_SENSOR = "go1_a_touches_go1_b"
SINGLE = go1_task.go1_flat_velocity_env_cfg()
"""The single-robot task whose MDP each agent runs."""


def go1_at(y_m: float):
    robot = go1_robot_cfg()
    return dataclasses.replace(robot, init_pos_m=(0.0, y_m, robot.init_pos_m[2]))


# -- scene: both robots in every env on flat ground, each with the single task's sensors, and a sensor of their contact
SCENE = SceneCfg(
    entities={"go1_a": go1_at(-SPAWN_OFFSET_Y_M), "go1_b": go1_at(SPAWN_OFFSET_Y_M)},
    terrain=None, env_spacing_m=4.0, ground_friction=SINGLE.scene.ground_friction,
    contact_sensors={
        **{f"{name}_contact_forces": dataclasses.replace(SINGLE.scene.contact_sensors[CONTACT_SENSOR], entity=name)
           for name in ROBOTS},
        TOUCH_SENSOR: ContactSensorCfg(entity="go1_a", filter_entity="go1_b", history_length=1, track_air_time=False),
        **trunk_on_ground_sensors({name: [BASE_BODY] for name in ROBOTS}),
    },
    height_scanners={f"{name}_base_height": dataclasses.replace(SINGLE.scene.height_scanners[BASE_HEIGHT_SENSOR],
                                                                entity=name) for name in ROBOTS},
)


@configclass
class PolicyObsCfg(VelocityPolicyObsCfg):
    other_robot: ObsTerm = other_robot_obs()


@configclass
class CriticObsCfg(VelocityCriticObsCfg):
    other_robot = other_robot_obs()


@configclass
class ObservationsCfg:
    """The single task's groups, each with where the other Go1 is after its own terms."""

    policy = PolicyObsCfg(controlled_joint_pos=SINGLE.observations.policy.controlled_joint_pos,
                          controlled_joint_vel=SINGLE.observations.policy.controlled_joint_vel)
    critic = CriticObsCfg()


@configclass
class RewardsCfg(go1_task.RewardsCfg):
    keep_clear = keep_clear_penalty()
    touch_other_robot = touch_penalty(TOUCH_SENSOR)  # both agents pay it


def go1_agent_cfg(entity: str, other: str) -> AgentCfg:
    """Velocity-Flat-Go1-v0's MDP driving `entity` at its 50 Hz, seeing where `other` is."""
    return AgentCfg(
        decimation=SINGLE.decimation,
        scene_names=velocity_scene_names(entity, other_robot=other),
        commands=go1_task.CommandsCfg(), actions=go1_task.ActionsCfg(), observations=ObservationsCfg(),
        rewards=RewardsCfg(), terminations=trunk_on_ground_terminations(SINGLE.terminations),
        events=dataclasses.replace(SINGLE.events, reset_base=uniform_root_reset(xy_range_m=RESET_XY_RANGE_M)))


@configclass
class SharedGo1VelocityEnvCfg(MultiAgentEnvCfg):
    num_envs = 4096
    episode_length_s = SINGLE.episode_length_s
    scene = SCENE
    sim = velocity_sim_cfg(max_contacts_per_world=2 * SINGLE.sim.solver.nconmax)  # the single task's, per robot
    agents = {"go1_a": go1_agent_cfg("go1_a", other="go1_b"), "go1_b": go1_agent_cfg("go1_b", other="go1_a")}
