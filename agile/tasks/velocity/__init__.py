"""Velocity tracking on rough terrain (AGILE's G1 and T1 velocity tasks). What the task registry needs from here
lives in this light module: `import agile.tasks` registers every task without importing the simulator."""

RANDOMISATION_EVENTS = ("physics_material", "actuator_gains", "upper_body_actuator_gains", "joint_friction",
                        "joint_armature", "body_mass", "base_mass", "body_com", "base_com", "base_external_wrench",
                        "extremities_external_wrench")
"""The startup domain randomisation and the random wrenches of `VelocityEventsCfg` (pushes and resets stay)."""

HUMANOID_SHIP_BAR = {"mean_terrain_level": 10.0, "fall_rate": 0.03, "all_rows_fall_rate": 0.10}
"""What a velocity policy for the humanoids trained anew must show to be shipped, after what the shipped T1 and G1
policies show (docs/velocity.md: mean terrain level 13.5 and 13.4 of 20, 0.2-1.0% falls on the start rows, 7.1-8.2%
spawned over all 20 rows): the training's mean terrain level at least 10, at most 3% falls on the start rows and at
most 10% over every row (`agile time_to_policy --target shippable`)."""
