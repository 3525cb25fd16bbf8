"""What the multi-agent velocity tasks share: the names an agent's velocity MDP (written for one "robot") uses for its
robot's entity and sensors in a world of several robots, and the penalty for touching another robot."""

from __future__ import annotations

from agile.rl_env.managers import RewTerm, SceneEntityCfg
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import BASE_HEIGHT_SENSOR, CONTACT_SENSOR


def velocity_scene_names(entity: str) -> dict[str, str]:
    """The velocity MDP's "robot" and its sensors -> `entity` and the world's `<entity>_contact_forces` and
    `<entity>_base_height` sensors."""
    return {"robot": entity, CONTACT_SENSOR: f"{entity}_contact_forces", BASE_HEIGHT_SENSOR: f"{entity}_base_height"}


def touch_penalty(sensor_name: str) -> RewTerm:
    """-1 per second while the contact sensor `sensor_name` (one robot filtered against another) reports a touch."""
    return RewTerm(func=mdp.filtered_contact, weight=-1.0,
                   params={"sensor_cfg": SceneEntityCfg(sensor_name), "force_threshold_n": 1.0})
