"""Load a dataset written by `agile record` with LeRobot's own code (the PyPI package `lerobot-dataset`, import name
`ledataset`) and check it against the files: frame and episode counts, episode boundaries, every row's state and
action, and video frames against the rows they belong to. Prints one JSON line; exit 1 if a check fails.

    python scripts/check_lerobot_dataset.py demos/

Runs in a Python environment with `lerobot-dataset` and a torch build that has torchvision and torchcodec (LeRobot
imports torchvision at load and decodes videos with torchcodec): not agile's CPU test environment, whose torch has
no matching torchvision. `lerobot-dataset` 0.4 reads LeRobot v3.0; agile writes GR00T's v2.1 layout, so the check
first converts a copy with the package's own converter (`convert_dataset_v21_to_v30`), as a LeRobot user would.
Uses nothing of agile: the dataset is read by code nobody here wrote.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from pathlib import Path


def main(dataset: Path) -> int:
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    os.environ.setdefault("HF_DATASETS_OFFLINE", "1")
    import av
    import numpy as np
    import pyarrow.parquet as pq
    from ledataset.datasets.lerobot_dataset import LeRobotDataset
    from ledataset.datasets.v30.convert_dataset_v21_to_v30 import convert_dataset

    info = json.loads((dataset / "meta/info.json").read_text())
    episodes = [json.loads(line) for line in (dataset / "meta/episodes.jsonl").read_text().splitlines()]
    video_keys = [k for k, f in info["features"].items() if f["dtype"] == "video"]
    checks: dict[str, bool] = {}
    with tempfile.TemporaryDirectory() as parent:
        copy = Path(parent) / "local" / "agile_record"
        shutil.copytree(dataset, copy)
        convert_dataset(repo_id="local/agile_record", root=Path(parent), push_to_hub=False)
        ds = LeRobotDataset(repo_id="local/agile_record", root=copy)
        checks["frames"] = len(ds) == info["total_frames"] == sum(e["length"] for e in episodes)
        checks["episodes"] = ds.num_episodes == info["total_episodes"] == len(episodes)
        checks["fps"] = ds.fps == info["fps"]
        bounds, start = [], 0
        for e in episodes:
            bounds.append((start, start + e["length"]))
            start += e["length"]
        read_bounds = [(int(e["dataset_from_index"]), int(e["dataset_to_index"])) for e in ds.meta.episodes]
        checks["episode_boundaries"] = read_bounds == bounds
        worst_pixel_error, rows_equal, done_at_ends = 0.0, True, True
        for e, (first, last) in zip(episodes, bounds):
            index = e["episode_index"]
            table = pq.read_table(dataset / info["data_path"].format(episode_chunk=index // info["chunks_size"],
                                                                     episode_index=index)).to_pydict()
            for row in range(last - first):
                item = ds[first + row]
                rows_equal &= int(item["episode_index"]) == index and int(item["frame_index"]) == row
                rows_equal &= np.allclose(item["observation.state"].numpy(), table["observation.state"][row])
                rows_equal &= np.allclose(item["action"].numpy(), table["action"][row])
                done_at_ends &= bool(item["next.done"]) == (row == last - first - 1)
            for key in video_keys:  # the first and last frame of each episode, decoded by LeRobot and by PyAV
                path = dataset / info["video_path"].format(episode_chunk=index // info["chunks_size"],
                                                           video_key=key, episode_index=index)
                with av.open(str(path)) as container:
                    frames = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
                checks.setdefault("video_frames_equal_rows", True)
                checks["video_frames_equal_rows"] &= len(frames) == last - first
                for row in (0, last - first - 1):
                    image = (ds[first + row][key].numpy().transpose(1, 2, 0) * 255.0).astype(np.float64)
                    worst_pixel_error = max(worst_pixel_error, float(np.abs(image - frames[row]).mean()))
        checks["rows_equal_parquet"] = bool(rows_equal)
        checks["done_only_at_episode_ends"] = bool(done_at_ends)
        checks["video_decodes_as_pyav"] = worst_pixel_error < 2.0
    print(json.dumps({"reader": "lerobot-dataset (ledataset) via convert_dataset_v21_to_v30", "checks": checks,
                      "frames": info["total_frames"], "episodes": info["total_episodes"],
                      "worst_mean_pixel_error": round(worst_pixel_error, 3)}))
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python scripts/check_lerobot_dataset.py DATASET_FOLDER")
    sys.exit(main(Path(sys.argv[1])))
