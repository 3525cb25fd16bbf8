"""What the multi-agent velocity tasks share: the names an agent's velocity MDP (written for one "robot") uses for its
robot's entity and sensors in a world of several robots, the trunk contact that ends an episode read from the
ground's force alone, the other robot as a robot sees it, and the penalties for coming close to and touching another
robot."""

from __future__ import annotations

import dataclasses

import torch

from agile.rl_env.managers import ROBOT, ObsTerm, RewTerm, SceneEntityCfg
from agile.sim import ContactSensorCfg
from agile.rl_env.mdp.symmetry import mirrored_by
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import BASE_HEIGHT_SENSOR, CONTACT_SENSOR
from agile.utils.math import world_to_heading_frame_xy

OTHER_ROBOT = "other_robot"
"""The name an agent's terms use for the world's other robot (`velocity_scene_names(..., other_robot=...)`)."""
TRUNK_ON_GROUND = "trunk_on_ground"
"""The name an agent's trunk-contact termination uses for its robot's sensor of the ground's force on its trunk: with
the net force a touch of the other robot was a fall (Shared-Go1-Velocity-v0 at iteration 1,850: 8 of 9 falls ended
by trunk contact spawned 1.5 m apart, none spawned 16 m apart; CPU, 48 envs x 20 s, seed 1, 2026-12-03)."""


def velocity_scene_names(entity: str, other_robot: str | None = None) -> dict[str, str]:
    """The velocity MDP's "robot" and its sensors -> `entity` and the world's `<entity>_contact_forces`,
    `<entity>_base_height` and `<entity>_trunk_on_ground` sensors; with `other_robot`, the name `OTHER_ROBOT` -> that
    entity."""
    names = {"robot": entity, CONTACT_SENSOR: f"{entity}_contact_forces", BASE_HEIGHT_SENSOR: f"{entity}_base_height",
             TRUNK_ON_GROUND: f"{entity}_{TRUNK_ON_GROUND}"}
    if other_robot is not None:
        names[OTHER_ROBOT] = other_robot
    return names


def trunk_on_ground_sensors(trunk_bodies: dict[str, list[str]]) -> dict[str, ContactSensorCfg]:
    """{entity: its trunk bodies} -> the scene's `<entity>_trunk_on_ground` sensors: the ground's force on them."""
    return {f"{entity}_{TRUNK_ON_GROUND}": ContactSensorCfg(entity=entity, body_names=list(bodies),
                                                            filter_entity="ground", history_length=1,
                                                            track_air_time=False)
            for entity, bodies in trunk_bodies.items()}


def trunk_on_ground_terminations(terminations):
    """A velocity task's terminations with its trunk contact (`illegal_ground_contact`) read from the ground's force
    alone (`TRUNK_ON_GROUND`; a touch of another robot is penalised, not a fall), the same bodies and thresholds."""
    contact = terminations.illegal_ground_contact
    sensor = dataclasses.replace(contact.params["sensor_cfg"], name=TRUNK_ON_GROUND)
    return dataclasses.replace(terminations, illegal_ground_contact=dataclasses.replace(
        contact, params={**contact.params, "sensor_cfg": sensor}))


@mirrored_by([0, 1, 2, 3], [1.0, -1.0, 1.0, -1.0])  # mirrored left-right: the other robot's y and vy flip
def other_robot_in_heading_frame(env, max_distance_m: float, asset_cfg: SceneEntityCfg = ROBOT,
                                 other_cfg: SceneEntityCfg = SceneEntityCfg(OTHER_ROBOT)) -> torch.Tensor:
    """(N, 4): the other robot's planar position [m] and velocity [m/s] relative to this robot's root, in this robot's
    heading frame (x forward, y left, gravity-aligned); the position clipped to +-`max_distance_m` per axis (what is
    farther does not change what to do now)."""
    robot, other = env.scene[asset_cfg.name], env.scene[other_cfg.name]
    position = world_to_heading_frame_xy(robot.heading_w, other.root_pos_w - robot.root_pos_w)
    velocity = world_to_heading_frame_xy(robot.heading_w, other.root_lin_vel_w - robot.root_lin_vel_w)
    return torch.cat((position.clamp(-max_distance_m, max_distance_m), velocity), dim=1)


def other_robot_obs(max_distance_m: float = 3.0) -> ObsTerm:
    """`other_robot_in_heading_frame` as an observation term (noise-free: the positions come from the world)."""
    return ObsTerm(func=other_robot_in_heading_frame, params={"max_distance_m": max_distance_m})


def closeness_to_other_robot(env, clearance_m: float, asset_cfg: SceneEntityCfg = ROBOT,
                             other_cfg: SceneEntityCfg = SceneEntityCfg(OTHER_ROBOT)) -> torch.Tensor:
    """(N,): 1 - d / `clearance_m` for the planar distance d [m] between the two roots, 0 from `clearance_m` on."""
    robot, other = env.scene[asset_cfg.name], env.scene[other_cfg.name]
    distance_m = torch.linalg.vector_norm(other.root_pos_w[:, :2] - robot.root_pos_w[:, :2], dim=1)
    return (1.0 - distance_m / clearance_m).clamp(min=0.0)


def keep_clear_penalty(clearance_m: float = 0.8, weight: float = -2.0) -> RewTerm:
    """`closeness_to_other_robot` as a penalty [per second]: the touch penalty alone comes too late and weighs little
    (-1 per second of touching against up to 3 per second of velocity tracking), so a robot that tracks its command
    into the other one loses almost nothing until they fall; this one grows from `clearance_m` between the roots (a
    Go1 is 0.65 m long with its legs), -1 per second at half of it, before the bodies meet."""
    return RewTerm(func=closeness_to_other_robot, weight=weight, params={"clearance_m": clearance_m})


def touch_penalty(sensor_name: str) -> RewTerm:
    """-1 per second while the contact sensor `sensor_name` (one robot filtered against another) reports a touch."""
    return RewTerm(func=mdp.filtered_contact, weight=-1.0,
                   params={"sensor_cfg": SceneEntityCfg(sensor_name), "force_threshold_n": 1.0})
