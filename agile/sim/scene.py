"""The scene: one world's template built from named entities, and `env.scene`, the entities and sensors by name."""

from __future__ import annotations

import newton
import torch

from agile.sim.camera import Camera
from agile.sim.contact_sensor import ContactSensor
from agile.sim.entities.articulation import Articulation
from agile.sim.entities.entity import Entity, EntityLayout, RigidObject
from agile.sim.entities.model_import import build_articulation, build_rigid_object, new_builder
from agile.sim.height_scanner import HeightScanner
from agile.sim.scene_cfg import GROUND, ArticulationCfg, RigidObjectCfg, SceneCfg
from agile.utils.config import ConfigError


def check_scene_names(cfg: SceneCfg) -> None:
    """Entities and sensors share one namespace (`env.scene[name]`): a name used twice is an error."""
    seen: dict[str, str] = {}
    for kind, names in (("entities", cfg.entities), ("contact_sensors", cfg.contact_sensors),
                        ("height_scanners", cfg.height_scanners), ("cameras", cfg.cameras)):
        for name in names:
            if name == GROUND:
                raise ConfigError(f"scene.{kind}: the name '{GROUND}' is reserved for the ground or terrain")
            if name in seen:
                raise ConfigError(f"scene.{kind}: the name '{name}' is already used in scene.{seen[name]}; "
                                  f"entities and sensors share one namespace")
            seen[name] = kind
    for name, entity in cfg.entities.items():
        if not isinstance(entity, (ArticulationCfg, RigidObjectCfg)):
            raise ConfigError(f"scene.entities.{name}: expected an ArticulationCfg or RigidObjectCfg, "
                              f"got {type(entity).__name__}")
    if not cfg.entities:
        raise ConfigError("scene.entities is empty: a world needs at least one entity")


def build_world_template(cfg: SceneCfg, gravity_mps2: float):
    """One world's builder with every entity added in order. Returns (builder, {name: layout},
    {name: (joint names, body names)})."""
    check_scene_names(cfg)
    template = new_builder(gravity_mps2)
    layouts: dict[str, EntityLayout] = {}
    names: dict[str, tuple[list[str], list[str]]] = {}
    for name, entity_cfg in cfg.entities.items():
        try:
            if isinstance(entity_cfg, ArticulationCfg):
                builder, joint_names, body_names = build_articulation(entity_cfg, gravity_mps2)
            else:
                builder, body_names = build_rigid_object(entity_cfg, name, gravity_mps2)
                joint_names = []
        except (ValueError, FileNotFoundError, KeyError) as err:
            raise ConfigError(f"scene.entities.{name}: {err}") from None
        start = (len(template.joint_q), len(template.joint_qd), template.body_count, template.joint_count)
        template.add_builder(builder)
        layouts[name] = EntityLayout(
            coords=slice(start[0], len(template.joint_q)), dofs=slice(start[1], len(template.joint_qd)),
            bodies=slice(start[2], template.body_count), joints=slice(start[3], template.joint_count),
            floating=builder.joint_type[0] == newton.JointType.FREE)
        names[name] = (joint_names, body_names)
    return template, layouts, names


def make_entities(cfg: SceneCfg, model: newton.Model, state: newton.State, control: newton.Control,
                  layouts: dict[str, EntityLayout], names: dict, step_dt_s: float, env_origins: torch.Tensor,
                  computed_effort) -> dict:
    entities: dict[str, Entity] = {}
    for name, entity_cfg in cfg.entities.items():
        joint_names, body_names = names[name]
        try:
            if isinstance(entity_cfg, ArticulationCfg):
                entities[name] = Articulation(name, entity_cfg, model, state, control, layouts[name], joint_names,
                                              body_names, step_dt_s, env_origins, computed_effort)
            else:
                entities[name] = RigidObject(name, model, state, layouts[name], body_names, step_dt_s, env_origins,
                                             entity_cfg.body_type)
        except ValueError as err:
            raise ConfigError(f"scene.entities.{name}: {err}") from None
    return entities


def entity_of(entities: dict, name: str, where: str) -> Entity:
    if name not in entities:
        raise ConfigError(f"{where}: no entity '{name}' in the scene. Entities: {sorted(entities)}")
    return entities[name]


def filter_shape_ids(entities: dict, sensor_cfg, ground_shape: int, where: str):
    """Global shape indices (all worlds) a contact sensor's filter names, or None without a filter."""
    if sensor_cfg.filter_entity is None:
        return None
    if sensor_cfg.filter_entity == GROUND:
        return [ground_shape]
    entity = entity_of(entities, sensor_cfg.filter_entity, f"{where}.filter_entity")
    try:
        body_ids, _ = entity.find_bodies(sensor_cfg.filter_body_names)
    except ValueError as err:
        raise ConfigError(f"{where}.filter_body_names: {err}") from None
    selected = torch.isin(entity.shape_body, torch.tensor(body_ids, device=entity.device))
    shapes = entity.shape_ids[:, selected].flatten().tolist()
    if not shapes:
        raise ConfigError(f"{where}: the filter bodies of '{sensor_cfg.filter_entity}' have no collision shapes")
    return sorted(shapes)


class Scene:
    """`env.scene`: every entity and sensor by name (`env.scene["robot"]`, `env.scene["contact_forces"]`)."""

    def __init__(self, entities: dict[str, Entity], contact_sensors: dict[str, ContactSensor],
                 height_scanners: dict[str, HeightScanner], cameras: dict[str, Camera] | None = None):
        self.entities = entities
        self.articulations = {k: v for k, v in entities.items() if isinstance(v, Articulation)}
        self.rigid_objects = {k: v for k, v in entities.items() if isinstance(v, RigidObject)}
        self.contact_sensors = contact_sensors
        self.height_scanners = height_scanners
        self.cameras = cameras or {}
        self._all = {**entities, **contact_sensors, **height_scanners, **self.cameras}

    def __getitem__(self, name: str):
        if name not in self._all:
            raise KeyError(f"no entity or sensor '{name}' in the scene. Entities: {sorted(self.entities)}; "
                           f"sensors: {sorted(self.contact_sensors) + sorted(self.height_scanners) + sorted(self.cameras)}")
        return self._all[name]

    def __contains__(self, name: str) -> bool:
        return name in self._all

    def keys(self):
        return self._all.keys()

    # -- per env step ---------------------------------------------------------------------------

    def update(self) -> None:
        """Derived quantities after a state change (physics or reset): root frames, then the height scans."""
        for entity in self.entities.values():
            entity.update()
        # once per step, after the entities: several terms read the same rays
        for scanner in self.height_scanners.values():
            scanner.update()
        for camera in self.cameras.values():  # rendered when next read
            camera.mark_stale()

    def update_after_physics(self) -> None:
        """`update`, plus finite-difference accelerations and actuator torques: once per env step."""
        self.update()
        for entity in self.entities.values():
            entity.update_accelerations()
        for articulation in self.articulations.values():
            articulation.compute_pd_torque()

    def state_is_valid(self, max_joint_speed_rad_s: float) -> torch.Tensor:
        """(N,) bool: every entity's state is finite and no joint is faster than the limit."""
        valid = None
        for entity in self.entities.values():
            ok = entity.state_is_valid(max_joint_speed_rad_s)
            valid = ok if valid is None else valid & ok
        return valid

    def reset_to_default(self, mask: torch.Tensor) -> None:
        """Every entity at its default state at its env origin where mask (N,) is True (actuators cleared)."""
        for entity in self.entities.values():
            entity.reset_to_default(mask)
        for articulation in self.articulations.values():
            articulation.reset_actuators(mask)
