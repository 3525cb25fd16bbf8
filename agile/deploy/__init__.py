"""Running an exported policy on a robot through the robot's own SDK (`agile deploy`), and a DDS robot simulator in
plain MuJoCo (`agile sim_robot`) that stands in for the robot.

- `robots`: the robots deploy drives (motor order, MJCF, joint limits) and a bundle checked against one.
- `policy`: a LEAPP bundle fed from the robot's state (motor order in, targets and gains in motor order out).
- `safety`: the state machine (passive -> move to the default pose -> hold -> policy -> damping) and its faults.
- `controller`: the control loop at the policy's rate, its latency and jitter.
- `unitree_g1`: the G1 over Unitree's DDS (`unitree_hg` LowState_/LowCmd_, CRC, the wireless remote).
- `booster_t1`: the T1 over the Booster SDK (as far as its Python binding goes).
- `simulator`: the G1 in MuJoCo behind `rt/lowstate` / `rt/lowcmd`, with fault switches.

The SDKs are the `agile[deploy]` extra; this package imports them only where it talks to a robot.
"""
