"""A DDS robot simulator in plain MuJoCo: the G1 behind `rt/lowstate` / `rt/lowcmd`, so that `agile deploy` runs
without a robot.

    agile sim_robot --robot g1 &
    agile deploy --bundle exported/leapp/Velocity-G1-History-v0/Velocity-G1-History-v0.yaml --interface lo \\
        --autostart --duration_s 20 --command 0.5 0 0

Steps the robot's MJCF in real time at its physics step (the robot config's, 5 ms), publishes LowState_ (IMU
quaternion, gyro and accelerometer, joint q/dq/tau, the remote) every step and applies the newest LowCmd_ as the
motor drivers do (per-motor PD from q, dq, kp, kd plus tau, within the actuator limits). The pelvis hangs on a
gantry until --gantry_release_s after the first command with stiffness. Fault switches: --latency_s,
--drop_rate, --freeze_after_s, --stop_after_s. Runs until Ctrl-C (or --duration_s); --out writes its counters and
the walk's samples (50 Hz) as JSON. The t1 is not simulated: the Booster SDK's Python binding has no LowState
publisher (docs/howto/deploy.md).
"""

from __future__ import annotations

import json
import signal
import threading
from pathlib import Path

from agile.errors import AgileError
from agile.run import arguments
from agile.run.deploy import exit_without_dds_teardown


@arguments.command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--robot", default="g1", help="the robot to simulate: g1")
    parser.add_argument("--interface", default="lo", help="the network interface DDS runs on")
    parser.add_argument("--domain_id", type=int, default=0, help="the DDS domain")
    parser.add_argument("--physics_dt_s", type=float, default=None, help="the physics step (default: the robot "
                        "config's, 0.005)")
    parser.add_argument("--gantry_release_s", type=float, default=2.5,
                        help="the gantry lets the pelvis go this long after the first command with stiffness")
    parser.add_argument("--latency_s", type=float, default=0.0, help="each command applied this long after arrival")
    parser.add_argument("--drop_rate", type=float, default=0.0, help="the fraction of state messages dropped")
    parser.add_argument("--freeze_after_s", type=float, default=None,
                        help="from then on the same state message (tick included) is sent again and again")
    parser.add_argument("--stop_after_s", type=float, default=None, help="from then on no state message is sent")
    parser.add_argument("--duration_s", type=float, default=None, help="simulated seconds, then exit")
    parser.add_argument("--seed", type=int, default=0, help="seed of the dropped messages")
    parser.add_argument("--out", default=None, metavar="PATH.json", help="write counters and samples here at exit")
    args = parser.parse_args(argv)  # not arguments.parse: it initialises Warp, unused here, before the input is checked
    if args.robot != "g1":
        raise AgileError(f"--robot: sim_robot simulates g1 only (the Booster SDK's Python binding publishes no T1 "
                         f"LowState); got '{args.robot}'")
    if not 0 <= args.drop_rate < 1:
        raise AgileError(f"--drop_rate must be in [0, 1), got {args.drop_rate}")
    for name in ("latency_s", "gantry_release_s"):
        if getattr(args, name) < 0:
            raise AgileError(f"--{name} must be at least 0, got {getattr(args, name)}")
    for name in ("physics_dt_s", "freeze_after_s", "stop_after_s", "duration_s"):
        if getattr(args, name) is not None and getattr(args, name) <= 0:
            raise AgileError(f"--{name} must be positive, got {getattr(args, name)}")
    if not 0 <= args.domain_id <= 232:
        raise AgileError(f"--domain_id must be in 0..232 (DDS), got {args.domain_id}")
    from agile.deploy.robots import DeployError
    from agile.deploy.unitree_g1 import check_interface

    try:
        check_interface(args.interface)
    except DeployError as err:
        raise AgileError(str(err)) from None
    try:
        import unitree_sdk2py  # noqa: F401
    except ImportError:
        raise AgileError("sim_robot needs the unitree_sdk2py package: pip install 'agile[deploy]'")
    from agile.deploy.simulator import DDSRobotSimulator, G1Simulation, SimFaults, g1_robot_config
    from agile.deploy.unitree_g1 import start_dds

    start_dds(args.interface, args.domain_id)
    sim = G1Simulation(g1_robot_config(), physics_dt_s=args.physics_dt_s, gantry_release_s=args.gantry_release_s)
    faults = SimFaults(command_latency_s=args.latency_s, state_drop_rate=args.drop_rate,
                       freeze_after_s=args.freeze_after_s, stop_after_s=args.stop_after_s)
    simulator = DDSRobotSimulator(sim, faults, seed=args.seed)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    print(f"[sim_robot] g1 on interface {args.interface}, DDS domain {args.domain_id}: publishing rt/lowstate every "
          f"{sim.dt_s * 1e3:.1f} ms", flush=True)
    summary = simulator.run(args.duration_s, stop)
    summary.update({"interface": args.interface, "domain_id": args.domain_id})
    fell = summary["fell_at_sim_s"]
    print(f"[sim_robot] {summary['sim_time_s']:.1f} s simulated (real-time factor {summary['real_time_factor']:.3f}), "
          f"{summary['commands_received']} commands, {'fell at %.2f s' % fell if fell is not None else 'no fall'}",
          flush=True)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps(summary))
    exit_without_dds_teardown(0)


if __name__ == "__main__":
    main()
