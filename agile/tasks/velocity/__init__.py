"""Velocity tracking on rough terrain (AGILE's G1 and T1 velocity tasks). What the task registry needs from here
lives in this light module: `import agile.tasks` registers every task without importing the simulator."""

RANDOMISATION_EVENTS = ("physics_material", "actuator_gains", "upper_body_actuator_gains", "joint_friction",
                        "joint_armature", "body_mass", "base_mass", "body_com", "base_com", "base_external_wrench",
                        "extremities_external_wrench")
"""The startup domain randomisation and the random wrenches of `VelocityEventsCfg` (pushes and resets stay)."""
