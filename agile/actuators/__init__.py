"""Actuator models and gain helpers."""

from agile.actuators.implicit import ImplicitActuatorCfg, JointValue

__all__ = ["ImplicitActuatorCfg", "JointValue"]
