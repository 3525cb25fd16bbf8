"""MultiRate-G1-T1-Velocity-v0: a Unitree G1 at 50 Hz and a Booster T1 at 25 Hz walk side by side in every env,
each following its own velocity command, without touching the other.

Each agent's MDP is its robot's velocity task (commands, actions, observations, rewards, terminations) term for
term, written for "robot" and mapped onto this scene's entities by `scene_names`; added to both: a penalty for
touching the other robot, and the trunk contact that ends an episode is the ground's alone (a touch of the other
robot is penalised, not a fall). Flat ground, no domain randomisation, arms held at their default pose (the conditions
of the shipped G1 policy), pushes kept.
"""

from __future__ import annotations

import dataclasses

from agile.assets.booster_t1 import t1_robot_cfg
from agile.assets.unitree_g1 import g1_robot_cfg
from agile.marl import AgentCfg, MultiAgentEnvCfg
from agile.sim import ContactSensorCfg, HeightScannerCfg, SceneCfg
from agile.tasks.multi_agent.velocity_agents import (touch_penalty, trunk_on_ground_sensors,
                                                    trunk_on_ground_terminations, velocity_scene_names)
from agile.tasks.velocity.g1 import velocity_history_env_cfg as g1_task
from agile.tasks.velocity.t1 import velocity_env_cfg as t1_task
from agile.tasks.velocity.velocity_common import (uniform_root_reset, velocity_events_cfg, velocity_sim_cfg,
                                                   velocity_terminations_cfg)
from agile.utils.config import configclass

SPAWN_OFFSET_Y_M = 1.0
"""Each robot spawns this far from the env origin, the G1 to the right (-y), the T1 to the left."""
RESET_XY_RANGE_M = 0.4
"""Reset positions within ±0.4 m of the spawn point: the robots never start inside each other."""
TOUCH_SENSOR = "g1_touches_t1"
TRUNK_BODIES = {"g1": ["torso_link", "pelvis"], "t1": ["Trunk", "Waist"]}
"""Each robot's bodies whose contact with the ground (one of them below 0.45 m) ends an episode."""

# -- scene: both robots in every env, each with its velocity task's sensors, and a sensor of their contact
SCENE = SceneCfg(
    entities={
        "g1": dataclasses.replace(g1_robot_cfg(), init_pos_m=(0.0, -SPAWN_OFFSET_Y_M, g1_robot_cfg().init_pos_m[2])),
        "t1": dataclasses.replace(t1_robot_cfg(), init_pos_m=(0.0, SPAWN_OFFSET_Y_M, t1_robot_cfg().init_pos_m[2])),
    },
    terrain=None, env_spacing_m=5.0, ground_friction=1.0,
    contact_sensors={
        "g1_contact_forces": ContactSensorCfg(entity="g1", body_names=["pelvis", "torso_link", *g1_task.FOOT_BODIES],
                                              history_length=3, track_air_time=True),
        "t1_contact_forces": ContactSensorCfg(entity="t1", body_names=["Trunk", "Waist", *t1_task.FOOT_BODIES],
                                              history_length=3, track_air_time=True),
        TOUCH_SENSOR: ContactSensorCfg(entity="g1", filter_entity="t1", history_length=1, track_air_time=False),
        **trunk_on_ground_sensors(TRUNK_BODIES),
    },
    height_scanners={"g1_base_height": HeightScannerCfg(entity="g1", body_name="pelvis"),
                     "t1_base_height": HeightScannerCfg(entity="t1", body_name="Trunk")},
)


def velocity_agent_cfg(task, entity: str, decimation: int, rewards, base_body: str) -> AgentCfg:
    """The velocity task `task` (its module) as an agent driving `entity` every `decimation` physics steps: its
    commands, actions (arms at default), observations and terminations, `rewards`, and its events without
    randomisation, on this scene's `<entity>_contact_forces` and `<entity>_base_height` sensors."""
    events = velocity_events_cfg(base_body=base_body, base_mass_add_kg=(0.0, 0.0), base_com_range_m={},
                                 extremity_bodies=task.FOOT_BODIES, randomise=False,
                                 reset_base=uniform_root_reset(xy_range_m=RESET_XY_RANGE_M))
    return AgentCfg(
        decimation=decimation,
        scene_names=velocity_scene_names(entity),
        commands=task.CommandsCfg(), actions=dataclasses.replace(task.ActionsCfg(), random_pos=None),
        observations=task.ObservationsCfg(), rewards=rewards,
        terminations=trunk_on_ground_terminations(
            velocity_terminations_cfg(task.BASE_HEIGHT_TARGET_M, trunk_bodies=TRUNK_BODIES[entity])),
        events=events)


# -- the G1 agent: 50 Hz, Velocity-G1-History-v0's MDP
@configclass
class G1RewardsCfg(g1_task.RewardsCfg):
    touch_other_robot = touch_penalty(TOUCH_SENSOR)  # either agent pays it


def g1_agent_cfg() -> AgentCfg:
    return velocity_agent_cfg(g1_task, "g1", decimation=4, rewards=G1RewardsCfg(), base_body="pelvis")


# -- the T1 agent: 25 Hz, Velocity-T1-v0's MDP
@configclass
class T1RewardsCfg(t1_task.RewardsCfg):
    touch_other_robot = touch_penalty(TOUCH_SENSOR)  # either agent pays it


def t1_agent_cfg() -> AgentCfg:
    return velocity_agent_cfg(t1_task, "t1", decimation=8, rewards=T1RewardsCfg(), base_body="Trunk")


@configclass
class MultiRateG1T1VelocityEnvCfg(MultiAgentEnvCfg):
    num_envs = 4096
    episode_length_s = 20.0
    scene = SCENE
    sim = velocity_sim_cfg(max_contacts_per_world=256)
    agents = {"g1": g1_agent_cfg(), "t1": t1_agent_cfg()}
