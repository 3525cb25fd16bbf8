"""Scene entities: articulations and rigid objects, with zero-copy views and masked writes."""

from agile.sim.entities.articulation import Articulation
from agile.sim.entities.entity import Entity, EntityLayout, RigidObject

__all__ = ["Articulation", "Entity", "EntityLayout", "RigidObject"]
