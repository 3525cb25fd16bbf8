"""Measure `agile deploy` against `agile sim_robot` on this machine: the walk (falls, velocity errors over the policy's
time) and the control loop's state-to-command latency and jitter; one run, written as JSON with the machine, load,
commit and date (docs/results/deploy/).

    python scripts/measure_deploy.py --bundle exported/leapp/Velocity-G1-History-v0/Velocity-G1-History-v0.yaml \\
        --command 0.5 0 0 --duration_s 20 --out docs/results/deploy/walk_dds_g1_0.5mps.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import signal
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def cpu_model() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bundle", required=True)
    parser.add_argument("--command", type=float, nargs=3, default=[0.5, 0.0, 0.0])
    parser.add_argument("--duration_s", type=float, default=20.0)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    from agile.deploy.simulator import walk_metrics

    domain_id = random.randint(100, 230)
    with tempfile.TemporaryDirectory() as tmp:
        sim_out, log = Path(tmp) / "sim.json", Path(tmp) / "deploy.json"
        sim = subprocess.Popen([sys.executable, "-m", "agile", "sim_robot", "--domain_id", str(domain_id), "--out",
                                str(sim_out)], cwd=REPO, stdout=subprocess.PIPE, text=True)
        sim.stdout.readline()  # its first line: publishing
        load_before = os.getloadavg()
        deploy = subprocess.run([sys.executable, "-m", "agile", "deploy", "--bundle", args.bundle, "--interface", "lo",
                                 "--domain_id", str(domain_id), "--autostart", "--duration_s", str(args.duration_s),
                                 "--command", *map(str, args.command), "--log", str(log)], cwd=REPO, timeout=300)
        load_after = os.getloadavg()
        sim.send_signal(signal.SIGINT)
        sim.wait(timeout=30)
        run, summary = json.loads(log.read_text()), json.loads(sim_out.read_text())
    walk = walk_metrics(summary["samples"], run["policy_started_s"], run["policy_ended_s"], np.array(args.command))
    window = [s for s in summary["samples"] if run["policy_started_s"] <= s[0] <= run["policy_ended_s"]]
    fell_at = summary["fell_at_sim_s"]  # simulated time; the policy's window in it from the samples
    fell = fell_at is not None and window[0][1] <= fell_at <= window[-1][1]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                            text=True).stdout.strip()
    out = {"date": datetime.now(timezone.utc).strftime("%Y-%m-%d"), "commit": commit, "cpu": cpu_model(),
           "cpu_count": os.cpu_count(), "load_average_1_5_15_before": load_before,
           "load_average_1_5_15_after": load_after, "bundle": Path(args.bundle).name, "command": args.command,
           "policy_duration_s": args.duration_s, "deploy_exit_code": deploy.returncode, "fault": run["fault"],
           "transitions": run["transitions"], "fell_during_policy": bool(fell), "walk": walk,
           "timing": run["timing"], "commands_written": run["commands_written"],
           "simulator": {k: summary[k] for k in ("physics_dt_s", "real_time_factor", "overruns", "states_published",
                                                 "commands_received", "commands_nonfinite", "commands_bad_crc")}}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=2))
    print(json.dumps({k: out[k] for k in ("fault", "fell_during_policy", "walk", "timing")}, indent=2))


if __name__ == "__main__":
    main()
