"""Run an exported policy on a robot through its own SDK over DDS, with the safety state machine: a LEAPP bundle
(--bundle), or the IO descriptor and policy file of `agile export` (--io, --policy).

    agile export --task Velocity-G1-History-v0 --format leapp --out exported/leapp
    agile sim_robot --robot g1 &                                    # or the real G1, in its debug mode
    agile deploy --bundle exported/leapp/Velocity-G1-History-v0/Velocity-G1-History-v0.yaml \\
        --interface lo --autostart --duration_s 20 --command 0.5 0 0

The command: fixed (--command), typed (VX VY WZ [HEIGHT] + Enter), the G1's remote sticks (--remote), or a DDS topic
of geometry_msgs/Twist (--command_topic rt/cmd_vel: ROS 2's /cmd_vel), always within the ranges the policy was
trained on; a topic silent for --command_timeout_s leaves the robot standing.

passive (zero torque) -> a timed move to the default pose -> hold -> policy -> damping. A start signal (Enter on the
keyboard, the remote's start then A with --remote, or --autostart) moves on; a stop (the keyboard's d + Enter, the
remote's select, Ctrl-C), a fall, a stale or frozen state stream, a joint past its limits or a policy output that is
not finite or out of range enters damping, from which only a restart leaves. Every transition is printed with its
cause. Exit 0 after a stop or --duration_s, 1 after a fault, 2 for input refused before anything is written.
Needs `pip install 'agile[deploy]'` (the robots' SDKs) and 'agile[leapp]' (the bundle's runtime).
"""

from __future__ import annotations

import gc
import json
import os
import signal
import sys
import threading
from collections import Counter
from pathlib import Path

import numpy as np

from agile.errors import AgileError
from agile.run import arguments

EXIT_FAULT = 1


def keyboard(signals, command) -> None:
    """Enter: start; d (or q) then Enter: stop; VX VY WZ [HEIGHT] then Enter: the command. Read from stdin in a daemon
    thread."""
    from agile.deploy.commands import parse_keyboard_line

    for line in sys.stdin:
        values = parse_keyboard_line(line)
        if line.strip().lower() in ("d", "q", "stop"):
            signals.stop = "the keyboard (stop)"
        elif values is not None:
            if not command.set(values, "the keyboard"):
                print(f"[deploy] the keyboard: '{line.strip()}' refused (3 to {len(command.value)} finite values)",
                      flush=True)
        else:
            signals.start = True


def parse_args(argv):
    parser = arguments.new_parser(__doc__)
    parser.add_argument("--bundle", default=None, metavar="TASK.yaml", help="a LEAPP bundle (agile export "
                        "--format leapp)")
    parser.add_argument("--io", default=None, metavar="io_descriptor.yaml", help="an IO descriptor (agile export), "
                        "with --policy")
    parser.add_argument("--policy", default=None, metavar="policy.onnx", help="policy.onnx or policy.pt beside "
                        "the IO descriptor (with --io)")
    parser.add_argument("--robot", default="g1", help="the robot: g1 (Unitree DDS) or t1 (Booster SDK)")
    parser.add_argument("--interface", required=True, help="the network interface on the robot's network (lo for "
                        "agile sim_robot)")
    parser.add_argument("--domain_id", type=int, default=0, help="the DDS domain (the robots' own: 0)")
    parser.add_argument("--command", type=float, nargs="+", default=None, metavar="V",
                        help="a fixed command VX VY WZ [HEIGHT] (default: standing, at the default height; with "
                        "--remote, the sticks set VX VY WZ)")
    parser.add_argument("--remote", action="store_true", help="the G1's wireless remote (in LowState_): start, A "
                        "and select buttons, the sticks as the velocity command")
    parser.add_argument("--command_topic", default=None, metavar="TOPIC", help="a DDS topic of geometry_msgs/Twist "
                        "(linear.x, linear.y, angular.z) as the velocity command, e.g. rt/cmd_vel (ROS 2's /cmd_vel); "
                        "g1 only")
    parser.add_argument("--command_timeout_s", type=float, default=0.5, help="the robot stands (zero velocity) while "
                        "the command topic has been silent this long")
    parser.add_argument("--autostart", action="store_true", help="no start signal: move, hold, then the policy")
    parser.add_argument("--duration_s", type=float, default=None, help="seconds of policy, then damping (default: "
                        "until a stop)")
    parser.add_argument("--damping_s", type=float, default=2.0, help="seconds of damping commands before the exit")
    parser.add_argument("--move_duration_s", type=float, default=2.0, help="the move to the default pose [s]")
    parser.add_argument("--max_state_age_s", type=float, default=None,
                        help="damping when the newest state is older (default: 3 control periods)")
    parser.add_argument("--max_tilt_deg", type=float, default=45.0, help="damping past this tilt (a fall)")
    parser.add_argument("--first_state_timeout_s", type=float, default=5.0,
                        help="how long to wait for the robot's first state message")
    parser.add_argument("--dry_run", action="store_true", help="compute everything, write no command")
    parser.add_argument("--log", default=None, metavar="PATH.json",
                        help="write the transitions, the loop's latency and jitter, and counters as JSON")
    args = parser.parse_args(argv)  # not arguments.parse: it initialises Warp, unused here, before the input is checked
    if (args.bundle is None) == (args.io is None and args.policy is None) or (args.io is None) != (args.policy is None):
        raise AgileError("give either --bundle, or --io and --policy (the exported policy to deploy)")
    for name in ("damping_s", "move_duration_s", "first_state_timeout_s", "max_tilt_deg", "command_timeout_s"):
        if getattr(args, name) <= 0:
            raise AgileError(f"--{name} must be positive, got {getattr(args, name)}")
    for name in ("duration_s", "max_state_age_s"):
        if getattr(args, name) is not None and getattr(args, name) <= 0:
            raise AgileError(f"--{name} must be positive, got {getattr(args, name)}")
    if not 0 <= args.domain_id <= 232:
        raise AgileError(f"--domain_id must be in 0..232 (DDS), got {args.domain_id}")
    return args


def prepare(args):
    """Everything checked before DDS starts: the robot, the bundle, the interface, the command, the SDKs."""
    from agile.deploy.robots import DeployError, read_deploy_bundle, read_deploy_descriptor, robot_spec
    from agile.deploy.unitree_g1 import check_interface

    try:
        spec = robot_spec(args.robot)
    except DeployError as err:
        raise AgileError(str(err)) from None
    if args.remote and spec.name != "g1":
        raise AgileError("--remote reads the G1's wireless remote in LowState_; the t1 has none in its SDK's LowState")
    if args.command_topic is not None and spec.name != "g1":
        raise AgileError("--command_topic is read over Unitree's DDS participant, which only the g1's link opens (the "
                         "t1's Booster SDK has its own)")
    if args.command_topic is not None and args.remote:
        raise AgileError("--command_topic and --remote: give one velocity source")
    try:
        if args.bundle is not None:
            bundle = read_deploy_bundle(args.bundle, spec)
        else:
            bundle = read_deploy_descriptor(args.io, args.policy, spec)
        check_interface(args.interface)
    except DeployError as err:
        raise AgileError(str(err)) from None
    command = default_command(bundle) if args.command is None else np.array(args.command)
    if command.shape != (bundle.command_size,):
        raise AgileError(f"--command: {bundle.task} takes {bundle.command_size} values "
                         f"({' '.join(bundle.command_elements)}), got {len(args.command)}")
    sdk = {"g1": "unitree_sdk2py", "t1": "booster_robotics_sdk_python"}[spec.name]
    try:
        __import__(sdk)
    except ImportError:
        raise AgileError(f"--robot {spec.name} needs the {sdk} package: pip install 'agile[deploy]'")
    return spec, bundle, command


def default_command(bundle) -> np.ndarray:
    """Standing still; a height command at the command's default height (else the top of its range), not 0 m."""
    command = np.zeros(bundle.command_size)
    if "base_height" in bundle.command_elements:
        term = next(iter(bundle.commands.values()))
        top = max(term.get("ranges", {}).get("base_height_m", [0.0]))
        command[bundle.command_elements.index("base_height")] = term.get("params", {}).get("default_height_m", top)
    return command


def policy_command(args, bundle, command):
    """The command the loop reads each period (agile.deploy.commands), its events printed as they happen."""
    from agile.deploy.commands import PolicyCommand, command_ranges

    lower, upper = command_ranges(bundle.commands, bundle.command_elements)
    per_state = None
    if args.remote:
        from agile.deploy.unitree_g1 import Remote

        limits = [max(abs(lower[i]), abs(upper[i])) for i in range(3)]
        per_state = lambda state: Remote.parse(state.remote).velocity_command(*limits)  # noqa: E731
    return PolicyCommand(initial=command, lower=lower, upper=upper, stream_timeout_s=args.command_timeout_s,
                         per_state=per_state, on_event=lambda e: print(f"[deploy] {e.text}", flush=True))


def open_link(spec, args):
    if spec.name == "g1":
        from agile.deploy.unitree_g1 import G1Link, start_dds

        start_dds(args.interface, args.domain_id)
        return G1Link()
    from agile.deploy.booster_t1 import T1Link, start_dds

    start_dds(args.interface, args.domain_id)
    return T1Link()


@arguments.command
def main(argv=None) -> None:
    args = parse_args(argv)
    spec, bundle, command = prepare(args)
    from agile.deploy.controller import Controller, Signals
    from agile.deploy.policy import DeployPolicy
    from agile.deploy.safety import SafetyLimits, SafetyStateMachine

    import torch

    torch.set_num_threads(1)  # a TorchScript policy runs once per period: an intra-op pool would only contend
    policy = DeployPolicy(bundle, spec)
    command_input = policy_command(args, bundle, command)
    lower_q, upper_q = spec.joint_limits()
    limits = SafetyLimits(max_state_age_s=args.max_state_age_s or 3 * bundle.control_dt_s,
                          max_tilt_rad=float(np.radians(args.max_tilt_deg)), move_duration_s=args.move_duration_s)

    def log(t):
        age = "no state yet" if t.state_age_s is None else f"state age {t.state_age_s * 1e3:.1f} ms"
        print(f"[deploy] {t.source.value} -> {t.target.value}: {t.cause} ({age})", flush=True)

    machine = SafetyStateMachine(limits, lower_q, upper_q, autostart=args.autostart, on_transition=log)
    signals = Signals()

    def on_signal(signum, _frame):
        signals.stop = f"{signal.Signals(signum).name} (Ctrl-C)" if signum == signal.SIGINT else signal.Signals(
            signum).name
    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    if sys.stdin is not None and sys.stdin.isatty() and not args.autostart:
        threading.Thread(target=keyboard, args=(signals, command_input), daemon=True).start()
        print("[deploy] Enter: start (passive -> move to default, hold -> policy); d + Enter: stop; VX VY WZ + Enter: "
              "the command", flush=True)
    link = open_link(spec, args)
    listeners = []  # kept for the whole run: a DDS subscription ends with its object
    if args.command_topic is not None:
        from agile.deploy.unitree_g1 import VelocityTopic

        listeners.append(VelocityTopic(args.command_topic, command_input.set_velocity_stream))
    velocity_limit = np.zeros(len(spec.motor_joints))
    velocity_limit[policy.from_motor] = bundle.robot["velocity_limit"]
    controller = Controller(link=link, policy=policy, machine=machine, control_dt_s=bundle.control_dt_s,
                            velocity_limit=velocity_limit, command_source=command_input,
                            signals=signals, dry_run=args.dry_run, remote_buttons=args.remote)
    gc.collect()
    gc.freeze()  # what exists now is never scanned again: no whole-heap collection in the middle of a period
    if not wait_for_state(link, args.first_state_timeout_s, limits.max_state_age_s, signals):
        print(f"error: no robot state on interface {args.interface}, DDS domain {args.domain_id} within "
              f"{args.first_state_timeout_s} s (is the robot, or agile sim_robot, running on that domain?); nothing "
              f"was written", file=sys.stderr)
        exit_without_dds_teardown(EXIT_FAULT)
    if spec.name == "t1" and not args.dry_run:
        link.enter_custom_mode()
    print(f"[deploy] {bundle.task} on the {spec.name} at {1 / bundle.control_dt_s:.0f} Hz"
          f"{' (dry run: no command written)' if args.dry_run else ''}", flush=True)
    result = controller.run(policy_duration_s=args.duration_s, damping_s=args.damping_s)
    timing = result.timing(bundle.control_dt_s)
    print(f"[deploy] {result.commands_written} commands written; state-to-command latency "
          f"{fmt(timing.get('state_to_command_ms'))} ms", flush=True)
    if args.log:
        write_log(args, bundle, result, timing, link, machine, command_input)
    link.close()
    if machine.fault is not None:
        print(f"error: damping after a fault: {machine.fault}", file=sys.stderr)
    exit_without_dds_teardown(EXIT_FAULT if machine.fault is not None else 0)


def exit_without_dds_teardown(code: int) -> None:
    """Exit with `code` at once, output flushed, without the interpreter's teardown of the DDS objects: deleting a
    cyclonedds reader while its listener thread waits for the GIL can deadlock (seen once here: a finished deploy
    hung with every thread in a futex wait). The operating system closes the sockets; the peers see the participant
    go."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def wait_for_state(link, timeout_s: float, max_age_s: float, signals) -> bool:
    """Whether a state younger than `max_age_s` came within `timeout_s`."""
    import time

    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and signals.stop is None:
        state = link.latest()
        if state is not None and time.monotonic() - state.received_s < max_age_s:
            return True
        time.sleep(0.005)
    return False


def fmt(stats: dict | None) -> str:
    if not stats:
        return "-"
    return f"p50 {stats['p50']:.2f}, p99 {stats['p99']:.2f}, max {stats['max']:.2f}"


def write_log(args, bundle, result, timing, link, machine, command_input) -> None:
    """Times are time.monotonic() seconds (one clock for every process of the machine: the simulator's samples
    use it too)."""
    out = {"task": bundle.task, "bundle": args.bundle, "io": args.io, "policy": args.policy, "robot": args.robot,
           "interface": args.interface, "domain_id": args.domain_id, "command": command_input.summary(),
           "command_topic": args.command_topic, "dry_run": args.dry_run,
           "control_dt_s": bundle.control_dt_s, "fault": machine.fault,
           "transitions": [{"time_s": t.time_s, "from": t.source.value, "to": t.target.value, "cause": t.cause,
                            "state_age_s": t.state_age_s} for t in result.transitions],
           "policy_started_s": result.policy_started_s, "policy_ended_s": result.policy_ended_s,
           "commands_written": result.commands_written,
           "steps_by_mode": dict(Counter(r.mode for r in result.records)), "states_received": link.received,
           "states_bad_crc": link.bad_crc, "timing": timing,
           "last_state_received_s": None if link.latest() is None else link.latest().received_s}
    Path(args.log).parent.mkdir(parents=True, exist_ok=True)
    Path(args.log).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
