"""The `agile` command line.

    agile list                                   # every registered task: kind, shipped policy
    agile show Velocity-T1-v0                    # the resolved MDP (builds the env on CPU with 1 env)
    agile diff Velocity-T1-v0 Velocity-G1-History-v0   # the config paths whose values differ
    agile robot check path/to/robot.xml          # a robot model file's joints, bodies, actuators, problems
    agile train --task Velocity-T1-v0 ...        # train|play|eval|eval_all|export|benchmark|gpu_scaling|
                                                 # sim2mujoco|plot_learning_curve|time_to_policy|pick_checkpoint|
                                                 # record|fingerprint|deploy|sim_robot|robot:
                                                 # agile/run/<name>.py, in this process

`agile <command> --help` shows that command's options.
"""

from __future__ import annotations

import argparse
import importlib
import sys

import yaml

from agile.errors import AgileError
from agile.run.arguments import command

FORWARDED = ("train", "play", "eval", "eval_all", "export", "benchmark", "gpu_scaling", "sim2mujoco",
             "plot_learning_curve", "time_to_policy", "pick_checkpoint", "record", "fingerprint", "deploy", "sim_robot",
             "robot")
"""Subcommands that run `agile.run.<name>.main` with the arguments that follow."""


def check_task(task: str) -> None:
    """Raise an AgileError listing the registered tasks unless `task` is one."""
    from agile.tasks import task_spec

    task_spec(task)


def cmd_list(_args) -> None:
    """The registry only: no config, env or kernel is loaded for a listing."""
    import agile.tasks

    def shipped(task: str) -> str:
        files = agile.tasks.shipped_policy_files(task)
        return ",".join(str(p.relative_to(agile.tasks.PRETRAINED_DIR)) for p in files) or "-"

    rows = [(task, agile.tasks.task_kind(task), shipped(task)) for task in agile.tasks.registered_tasks()]
    width = max(len(task) for task, _, _ in rows)
    print(f"{'task':<{width}}  {'kind':<11}  shipped policy")
    for task, kind, policies in rows:
        print(f"{task:<{width}}  {kind:<11}  {policies}")


def cmd_show(args) -> None:
    check_task(args.task)
    import agile.tasks
    from agile.tasks.catalogue import task_entry
    from agile.tasks.describe import resolved_mdp
    from agile.utils.config import apply_overrides

    entry = task_entry(args.task)
    if entry.kind == "multi_agent":
        raise AgileError(f"agile show resolves single-agent tasks; {args.task} is multi-agent (its agents' tasks: "
                         f"{sorted(agile.tasks.task_spec(args.task).single_agent_baselines.values())})")
    env_cfg, _ = agile.tasks.load_cfgs(args.task)
    env_cfg.num_envs = 1
    apply_overrides({"env": env_cfg}, args.overrides)
    from agile.rl_env import ManagerBasedRLEnv

    print(f"[agile] building {args.task} on CPU with 1 env", file=sys.stderr, flush=True)
    env = ManagerBasedRLEnv(env_cfg, task_name=args.task, device="cpu")
    mdp = {"kind": entry.kind, "shipped_policy": entry.policy.name if entry.policy else None, **resolved_mdp(env)}
    if args.section:
        if args.section not in mdp:
            raise AgileError(f"no section '{args.section}'. Sections: {', '.join(mdp)}")
        mdp = {args.section: mdp[args.section]}
    # flow style for leaf lists: a joint list on one line
    print(yaml.safe_dump(mdp, sort_keys=False, width=120, default_flow_style=None), end="")


def cmd_diff(args) -> None:
    check_task(args.task_a)
    check_task(args.task_b)
    from agile.tasks.describe import config_diff, task_config_tree

    diff = config_diff(task_config_tree(args.task_a), task_config_tree(args.task_b))
    if not diff:
        print(f"{args.task_a} and {args.task_b} have the same configs")
        return
    print(f"# {len(diff)} paths differ: {args.task_a} -> {args.task_b}")
    for path, (a, b) in diff.items():
        print(f"{path}: {a!r} -> {b!r}")


def forward(command: str, argv: list[str]) -> int:
    """Run `agile.run.<command>.main(argv)` in this process; its exit code."""
    sys.argv[0] = f"agile {command}"  # what argparse names in its usage line
    return importlib.import_module(f"agile.run.{command}").main(argv) or 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="agile", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser("list", help="registered tasks with their kind and shipped policy").set_defaults(func=cmd_list)
    show = sub.add_parser("show", help="the resolved MDP of a task (builds it on CPU with 1 env)")
    show.add_argument("task")
    show.add_argument("--section", default=None, help="print only this section, e.g. rewards, observations, actuators")
    show.add_argument("overrides", nargs="*", help="env config overrides, env.<path>=<value>")
    show.set_defaults(func=cmd_show)
    diff = sub.add_parser("diff", help="the flattened config paths (env and agent) whose values differ")
    diff.add_argument("task_a")
    diff.add_argument("task_b")
    diff.set_defaults(func=cmd_diff)
    for name in FORWARDED:  # listed for --help; their arguments are parsed by the scripts themselves
        sub.add_parser(name, help=f"agile/run/{name}.py (agile {name} --help for its options)", add_help=False)
    return parser


@command
def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in FORWARDED:
        return forward(argv[0], argv[1:])
    args = build_parser().parse_args(argv)
    args.func(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
