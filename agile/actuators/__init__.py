"""Actuator models (implicit PD, delayed implicit PD, ideal PD, DC motor, delayed DC motor) and gain helpers."""

from agile.actuators.delayed_implicit import DelayedImplicitActuatorCfg, DelayedTargetGroup
from agile.actuators.explicit import DCMotorCfg, DelayedDCMotorCfg, ExplicitActuatorGroup, IdealPDActuatorCfg
from agile.actuators.gains import action_scale, armature_gains
from agile.actuators.implicit import ImplicitActuatorCfg, JointValue


def is_explicit(cfg) -> bool:
    """Whether an actuator cfg computes torques itself (joint_f) instead of handing gains to the solver."""
    return isinstance(cfg, IdealPDActuatorCfg)


__all__ = ["DCMotorCfg", "DelayedDCMotorCfg", "DelayedImplicitActuatorCfg", "DelayedTargetGroup",
           "ExplicitActuatorGroup", "IdealPDActuatorCfg", "ImplicitActuatorCfg", "JointValue", "action_scale",
           "armature_gains", "is_explicit"]
