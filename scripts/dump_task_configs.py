"""Every registered task's env and agent configs, resolved and written as `agile train` writes them
(params/env.yaml and params/agent.yaml: `agile.utils.config.to_dict`, callables as 'module:qualname'), one folder a
task; or two such dumps compared, field by field.

    python scripts/dump_task_configs.py dump OUT_DIR [--tasks ID ...]
    python scripts/dump_task_configs.py compare BEFORE_DIR AFTER_DIR

A refactoring that must not change behaviour dumps before and after and compares: `compare` lists every field that
differs (task, file, dotted path, both values) and exits 1 if any does, 0 if the dumps are identical.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import yaml

CONFIG_FILES = ("env.yaml", "agent.yaml")


def dump_task_configs(*, out_dir: Path, tasks: list[str] | None = None) -> list[str]:
    """Write <out_dir>/<task>/env.yaml and agent.yaml for `tasks` (default: every registered task); the tasks
    dumped. An unknown task raises KeyError naming the registered ones."""
    import agile.tasks
    from agile.utils.config import to_dict

    registered = agile.tasks.registered_tasks()
    tasks = registered if tasks is None else tasks
    unknown = sorted(set(tasks) - set(registered))
    if unknown:
        raise KeyError(f"unknown tasks {unknown}; registered: {registered}")
    for task in tasks:
        env_cfg, agent_cfg = agile.tasks.load_cfgs(task)
        folder = out_dir / task
        folder.mkdir(parents=True, exist_ok=True)
        for name, cfg in zip(CONFIG_FILES, (env_cfg, agent_cfg)):
            (folder / name).write_text(yaml.safe_dump(to_dict(cfg), sort_keys=False))
    return tasks


def _differences(before, after, path: str) -> list[tuple[str, object, object]]:
    if isinstance(before, dict) and isinstance(after, dict):
        found = []
        for key in list(before) + [k for k in after if k not in before]:
            found += _differences(before.get(key, "<absent>"), after.get(key, "<absent>"), f"{path}.{key}")
        if list(before) != list(after) and not found:
            found.append((path + " (key order)", list(before), list(after)))
        return found
    if isinstance(before, list) and isinstance(after, list) and len(before) == len(after):
        return [d for i, (b, a) in enumerate(zip(before, after)) for d in _differences(b, a, f"{path}[{i}]")]
    return [] if before == after else [(path, before, after)]


def compare_dumps(*, before_dir: Path, after_dir: Path) -> list[tuple[str, str, str, object, object]]:
    """(task, file, dotted path, before, after) of every difference between two dumps; a task or file present in
    one dump only is a difference too."""
    tasks = sorted({p.name for p in before_dir.iterdir() if p.is_dir()} | {p.name for p in after_dir.iterdir()
                                                                              if p.is_dir()})
    found = []
    for task in tasks:
        for name in CONFIG_FILES:
            paths = before_dir / task / name, after_dir / task / name
            if not all(p.is_file() for p in paths):
                found.append((task, name, "", *("present" if p.is_file() else "absent" for p in paths)))
                continue
            before, after = (yaml.safe_load(p.read_text()) for p in paths)
            found += [(task, name, path.lstrip("."), b, a) for path, b, a in _differences(before, after, "")]
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    verbs = parser.add_subparsers(dest="verb", required=True)
    dump = verbs.add_parser("dump", help="write every task's env.yaml and agent.yaml under OUT_DIR/<task>/")
    dump.add_argument("out_dir", type=Path)
    dump.add_argument("--tasks", nargs="+", default=None, help="these task IDs only (default: every registered one)")
    compare = verbs.add_parser("compare", help="list the differences of two dumps; exit 1 if there are any")
    compare.add_argument("before_dir", type=Path)
    compare.add_argument("after_dir", type=Path)
    args = parser.parse_args(argv)
    if args.verb == "dump":
        try:
            tasks = dump_task_configs(out_dir=args.out_dir, tasks=args.tasks)
        except KeyError as err:
            print(f"dump_task_configs: --tasks: {err.args[0]}", file=sys.stderr)
            return 2
        print(f"{len(tasks)} tasks' configs written under {args.out_dir}")
        return 0
    for path in (args.before_dir, args.after_dir):
        if not path.is_dir():
            print(f"dump_task_configs: {path} is not a folder of dumped configs", file=sys.stderr)
            return 2
    found = compare_dumps(before_dir=args.before_dir, after_dir=args.after_dir)
    for task, name, path, before, after in found:
        print(f"{task} {name} {path}: {before!r} -> {after!r}")
    print(f"{len(found)} differences" if found else "identical")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
