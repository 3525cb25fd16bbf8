"""The Newton world: building, stepping, state views, resets."""

from agile.sim.articulation import Articulation
from agile.sim.contact_sensor import ContactSensor
from agile.sim.names import resolve_names, resolve_values
from agile.sim.sim_cfg import ContactSensorCfg, RobotCfg, SimCfg, SolverCfg
from agile.sim.simulation import Simulation, build_robot, env_origins_grid

__all__ = ["Articulation", "ContactSensor", "ContactSensorCfg", "RobotCfg", "SimCfg", "Simulation", "SolverCfg",
           "build_robot", "env_origins_grid", "resolve_names", "resolve_values"]
