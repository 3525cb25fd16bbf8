"""A world of one robot named "robot", for tests of the simulation below the env."""

from agile.sim import ArticulationCfg, ContactSensorCfg, SceneCfg, SimCfg, Simulation


def robot_sim(robot: ArticulationCfg, num_envs: int, step_dt_s: float = 0.02, sim: SimCfg | None = None,
              contact_sensor: ContactSensorCfg | None = None, device: str = "cpu", **scene_fields) -> Simulation:
    """`Simulation` of `robot` alone; a contact sensor is named "contact_forces"; other SceneCfg fields pass on."""
    sensors = {} if contact_sensor is None else {"contact_forces": contact_sensor}
    scene = SceneCfg(entities={"robot": robot}, contact_sensors=sensors, **scene_fields)
    return Simulation(sim or SimCfg(), scene, num_envs, device, step_dt_s)
