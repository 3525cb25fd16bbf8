"""Demonstrations written as a LeRobot dataset in NVIDIA GR00T's layout (LeRobot v2.1: the v2.0 layout GR00T loads,
plus the per-episode statistics LeRobot's v2.1 readers and its v2.1 -> v3.0 converter need).

    meta/info.json, episodes.jsonl, tasks.jsonl, episodes_stats.jsonl, modality.json (GR00T), stats.json (GR00T)
    data/chunk-000/episode_000000.parquet            one row per control step
    videos/chunk-000/observation.images.<key>/episode_000000.mp4    one frame per row

Each env streams its own episode: rows are kept in memory, frames are encoded as they come (H.264, yuv420p,
a key frame every 2 frames as LeRobot encodes, timestamps exactly i / fps from 0 in every episode, which is what the
readers match video frames to rows by), in this process or in worker processes (`agile.run.video_encoders`). An
episode is written when it ends, whether by time-out or early, and gets the next episode index; an episode still
running when the recording stops is dropped with its video.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from agile.run.video_encoders import InlineEncoders, ProcessEncoders

CODEBASE_VERSION = "v2.1"
CHUNK_SIZE = 1000
DATA_PATH = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"
VIDEO_PATH = "videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4"
IMAGE_STATS_EVERY = 10
"""Image statistics from every 10th frame, 4x subsampled (LeRobot also estimates them from a sample)."""


@dataclass
class Slices:
    """Named parts of a vector column, in order: GR00T's modality.json slices."""

    parts: list[tuple[str, int]]
    names: list[str]

    def __post_init__(self):
        if sum(d for _, d in self.parts) != len(self.names):
            raise ValueError(f"{len(self.names)} names for parts of {sum(d for _, d in self.parts)} values")

    @property
    def dim(self) -> int:
        return len(self.names)

    def modality(self) -> dict:
        out, start = {}, 0
        for name, dim in self.parts:
            out[name] = {"start": start, "end": start + dim}
            start += dim
        return out


@dataclass
class _Episode:
    """One env's episode in progress."""

    videos: dict = field(default_factory=dict)  # key -> the video's temporary path
    states: list = field(default_factory=list)
    actions: list = field(default_factory=list)
    rewards: list = field(default_factory=list)
    dones: list = field(default_factory=list)
    image_sums: dict = field(default_factory=dict)  # key -> [count, sum, sum of squares, min, max] per channel


class LeRobotDatasetWriter:
    """Writes episodes into a new folder `root`; `streams` episodes are recorded at once (one per env). Videos are
    encoded in this process (`encode_processes` 0) or spread over that many worker processes."""

    def __init__(self, root: str | Path, fps: int, task_description: str, robot_type: str, state: Slices,
                 action: Slices, video_shapes: dict[str, tuple[int, int]], streams: int, encode_processes: int = 0):
        for key, (height, width) in video_shapes.items():
            if height % 2 or width % 2:
                raise ValueError(f"video '{key}' is {width} x {height}: H.264 in yuv420p needs even sizes")
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=False)
        self.fps = int(fps)
        self.task_description = task_description
        self.robot_type = robot_type
        self.state, self.action = state, action
        self.video_shapes = dict(video_shapes)
        self.episodes: list[dict] = []
        self.episode_stats: list[dict] = []
        self.total_frames = 0
        self._all_states: list[np.ndarray] = []
        self._all_actions: list[np.ndarray] = []
        self._open: list[_Episode | None] = [None] * streams
        self._temp = self.root / ".in_progress"
        self._temp.mkdir()
        self._begun = 0
        self._encoders = (ProcessEncoders(self.fps, encode_processes) if encode_processes > 0
                          else InlineEncoders(self.fps))

    # -- per frame ----------------------------------------------------------------------------------

    def add_frame(self, stream: int, state: np.ndarray, action: np.ndarray, reward: float, done: bool,
                  images: dict[str, np.ndarray]) -> None:
        """One control step of stream `stream`'s episode: the state and images before the step, the action taken,
        the reward it earned and whether the episode ended with it. Images are (H, W, 3) uint8."""
        episode = self._open[stream]
        if episode is None:
            episode = self._open[stream] = self._begin(stream)
        index = len(episode.states)
        episode.states.append(np.asarray(state, dtype=np.float32))
        episode.actions.append(np.asarray(action, dtype=np.float32))
        episode.rewards.append(float(reward))
        episode.dones.append(bool(done))
        for key, image in images.items():
            self._encoders.frame(stream, episode.videos[key], image, index)
            if index % IMAGE_STATS_EVERY == 0:
                _accumulate_image_stats(episode.image_sums, key, image[::4, ::4])

    def end_episode(self, stream: int) -> int:
        """Write stream `stream`'s episode (its last frame was added with done=True); returns its episode index."""
        episode = self._open[stream]
        if episode is None or not episode.states:
            raise ValueError(f"stream {stream} has no episode to end")
        self._open[stream] = None
        index = len(self.episodes)
        chunk = index // CHUNK_SIZE
        for key, temp_path in episode.videos.items():
            path = self.root / VIDEO_PATH.format(episode_chunk=chunk, video_key=f"observation.images.{key}",
                                                 episode_index=index)
            self._encoders.finish(stream, temp_path, path)
        columns = self._columns(episode, index)
        path = self.root / DATA_PATH.format(episode_chunk=chunk, episode_index=index)
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_parquet(columns, path)
        length = len(episode.states)
        self.episodes.append({"episode_index": index, "tasks": [self.task_description], "length": length})
        self.episode_stats.append({"episode_index": index, "stats": self._stats(columns, episode)})
        self._all_states.append(columns["observation.state"])
        self._all_actions.append(columns["action"])
        self.total_frames += length
        return index

    def drop_episode(self, stream: int) -> None:
        """Forget stream `stream`'s episode in progress (not ended when the recording stops)."""
        episode = self._open[stream]
        self._open[stream] = None
        if episode is not None:
            for temp_path in episode.videos.values():
                self._encoders.drop(stream, temp_path)

    def close(self) -> None:
        """Drop the episodes in progress and write the metadata."""
        for stream in range(len(self._open)):
            self.drop_episode(stream)
        self._encoders.close()
        self._temp.rmdir()
        meta = self.root / "meta"
        meta.mkdir(exist_ok=True)
        (meta / "info.json").write_text(json.dumps(self._info(), indent=2))
        _write_jsonl(meta / "episodes.jsonl", self.episodes)
        _write_jsonl(meta / "tasks.jsonl", [{"task_index": 0, "task": self.task_description}])
        _write_jsonl(meta / "episodes_stats.jsonl", self.episode_stats)
        (meta / "modality.json").write_text(json.dumps(self._modality(), indent=2))
        (meta / "stats.json").write_text(json.dumps(self._dataset_stats(), indent=2))

    # -- internals ----------------------------------------------------------------------------------

    def _begin(self, stream: int) -> _Episode:
        self._begun += 1  # a temporary name of its own: a worker may still be moving the stream's last video
        return _Episode(videos={key: self._temp / f"stream{stream}_{self._begun}_{key}.mp4"
                                for key in self.video_shapes})

    def _columns(self, episode: _Episode, index: int) -> dict[str, np.ndarray]:
        length = len(episode.states)
        frame_index = np.arange(length, dtype=np.int64)
        return {
            "observation.state": np.stack(episode.states),
            "action": np.stack(episode.actions),
            "timestamp": (frame_index / self.fps).astype(np.float32),
            "frame_index": frame_index,
            "episode_index": np.full(length, index, dtype=np.int64),
            "index": self.total_frames + frame_index,
            "task_index": np.zeros(length, dtype=np.int64),
            "annotation.human.action.task_description": np.zeros(length, dtype=np.int64),
            "next.reward": np.asarray(episode.rewards, dtype=np.float32),
            "next.done": np.asarray(episode.dones, dtype=bool),
        }

    def _stats(self, columns: dict[str, np.ndarray], episode: _Episode) -> dict:
        stats = {}
        for name, values in columns.items():
            values = values.reshape(len(values), -1).astype(np.float64)
            stats[name] = {"min": values.min(axis=0).tolist(), "max": values.max(axis=0).tolist(),
                           "mean": values.mean(axis=0).tolist(), "std": values.std(axis=0).tolist(),
                           "count": [len(values)]}
        for key, (frames, pixels, total, squares, low, high) in episode.image_sums.items():
            # LeRobot's image statistics: per channel, shape (3, 1, 1), of pixels in [0, 1]
            mean = total / pixels
            std = np.sqrt(np.maximum(squares / pixels - mean ** 2, 0.0))
            stats[f"observation.images.{key}"] = {
                **{name: [[[float(v)]] for v in value] for name, value in
                   (("min", low), ("max", high), ("mean", mean), ("std", std))}, "count": [frames]}
        return stats

    def _dataset_stats(self) -> dict:
        """GR00T's stats.json: min, max, mean, std and the 1st and 99th percentiles of the state and the action."""
        out = {}
        for name, chunks in (("observation.state", self._all_states), ("action", self._all_actions)):
            if not chunks:
                continue
            values = np.concatenate(chunks).astype(np.float64)
            out[name] = {"mean": values.mean(axis=0).tolist(), "std": values.std(axis=0).tolist(),
                         "min": values.min(axis=0).tolist(), "max": values.max(axis=0).tolist(),
                         "q01": np.quantile(values, 0.01, axis=0).tolist(),
                         "q99": np.quantile(values, 0.99, axis=0).tolist()}
        return out

    def _info(self) -> dict:
        scalar = {"shape": [1], "names": None}
        features = {}
        for key, (height, width) in self.video_shapes.items():
            features[f"observation.images.{key}"] = {
                "dtype": "video", "shape": [height, width, 3], "names": ["height", "width", "channels"],
                "info": {"video.height": height, "video.width": width, "video.codec": "h264",
                         "video.pix_fmt": "yuv420p", "video.is_depth_map": False, "video.fps": self.fps,
                         "video.channels": 3, "has_audio": False}}
        features["observation.state"] = {"dtype": "float32", "shape": [self.state.dim], "names": self.state.names}
        features["action"] = {"dtype": "float32", "shape": [self.action.dim], "names": self.action.names}
        for name, dtype in (("timestamp", "float32"), ("frame_index", "int64"), ("episode_index", "int64"),
                            ("index", "int64"), ("task_index", "int64"),
                            ("annotation.human.action.task_description", "int64"), ("next.reward", "float32"),
                            ("next.done", "bool")):
            features[name] = {"dtype": dtype, **scalar}
        episodes = len(self.episodes)
        return {"codebase_version": CODEBASE_VERSION, "robot_type": self.robot_type, "total_episodes": episodes,
                "total_frames": self.total_frames, "total_tasks": 1, "total_videos": episodes * len(self.video_shapes),
                "total_chunks": max(1, -(-episodes // CHUNK_SIZE)), "chunks_size": CHUNK_SIZE, "fps": self.fps,
                "splits": {"train": f"0:{episodes}"}, "data_path": DATA_PATH, "video_path": VIDEO_PATH,
                "features": features}

    def _modality(self) -> dict:
        return {"state": self.state.modality(), "action": self.action.modality(),
                "video": {key: {"original_key": f"observation.images.{key}"} for key in self.video_shapes},
                "annotation": {"human.action.task_description": {}}}


def _accumulate_image_stats(sums: dict, key: str, image: np.ndarray) -> None:
    """Add one (subsampled) frame to `sums[key]` = [frames, pixels, sum, sum of squares, min, max] per channel."""
    pixels = image.reshape(-1, 3).astype(np.float64) / 255.0
    if key not in sums:
        sums[key] = [0, 0, np.zeros(3), np.zeros(3), np.ones(3), np.zeros(3)]
    entry = sums[key]
    entry[0] += 1
    entry[1] += len(pixels)
    entry[2] += pixels.sum(axis=0)
    entry[3] += (pixels ** 2).sum(axis=0)
    entry[4] = np.minimum(entry[4], pixels.min(axis=0))
    entry[5] = np.maximum(entry[5], pixels.max(axis=0))


def _write_jsonl(path: Path, rows: list[dict]) -> None:
    path.write_text("".join(json.dumps(row) + "\n" for row in rows))


def _write_parquet(columns: dict[str, np.ndarray], path: Path) -> None:
    """The arrow types LeRobot writes: fixed-size float32 lists for vectors, plain scalars otherwise."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    arrays, fields = [], []
    for name, values in columns.items():
        if values.ndim == 2:
            kind = pa.list_(pa.float32(), values.shape[1])
            array = pa.FixedSizeListArray.from_arrays(pa.array(values.reshape(-1), pa.float32()), values.shape[1])
        else:
            kind = {np.dtype("float32"): pa.float32(), np.dtype("int64"): pa.int64(),
                    np.dtype("bool"): pa.bool_()}[values.dtype]
            array = pa.array(values, kind)
        arrays.append(array)
        fields.append(pa.field(name, kind))
    pq.write_table(pa.Table.from_arrays(arrays, schema=pa.schema(fields)), path)
