"""The Newton world: the scene's entities replicated into every world, stepping, state views, resets."""

from agile.sim.contact_sensor import ContactSensor
from agile.sim.entities import Articulation, Entity, RigidObject
from agile.sim.names import resolve_names, resolve_values
from agile.sim.scene import Scene
from agile.sim.camera import Camera
from agile.sim.scene_cfg import (GROUND, ArticulationCfg, BoxShapeCfg, CameraCfg, CapsuleShapeCfg, ContactSensorCfg,
                                 CylinderShapeCfg, HeightScannerCfg, MeshFileShapeCfg, ModelFileShapeCfg,
                                 RigidObjectCfg, SceneCfg, SphereShapeCfg)
from agile.sim.sim_cfg import SimCfg, SolverCfg
from agile.sim.simulation import Simulation, env_origins_grid

__all__ = ["GROUND", "Articulation", "ArticulationCfg", "BoxShapeCfg", "Camera", "CameraCfg", "CapsuleShapeCfg",
           "ContactSensor",
           "ContactSensorCfg", "CylinderShapeCfg", "Entity", "HeightScannerCfg", "MeshFileShapeCfg",
           "ModelFileShapeCfg", "RigidObject", "RigidObjectCfg", "Scene", "SceneCfg", "SimCfg", "Simulation",
           "SolverCfg", "SphereShapeCfg", "env_origins_grid", "resolve_names", "resolve_values"]
