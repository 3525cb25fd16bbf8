"""H.264 encoding of the recorder's videos, in the recording process or spread over worker processes.

Every video is one episode of one env (a "stream"): frames arrive in order, then the episode is finished (flushed
and moved to its final path) or dropped. PyAV holds the GIL while libx264 encodes, so threads do not help: one core
encodes a few hundred 640 x 480 frames/s, fewer than a GPU renders at 256 envs. `ProcessEncoders` sends each
frame's bytes through a pipe to one of its worker processes (`python -m agile.run.video_encoders FPS`), stream i
always to worker i % processes so that each video is encoded in order by one process. A pipe, not shared memory:
containers often mount a small /dev/shm.

Options as LeRobot encodes (H.264, yuv420p, a key frame every 2 frames, no B-frames); `crf` 18 keeps the frames
within a few levels of the rendered ones.
"""

from __future__ import annotations

import json
import queue
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np

VIDEO_OPTIONS = {"crf": "18", "g": "2", "bf": "0", "preset": "veryfast"}


class InlineEncoders:
    """The videos encoded in this process (libx264's own threads: `threads` 0 lets it choose)."""

    def __init__(self, fps: int, threads: int = 0):
        self.fps, self.threads = int(fps), threads
        self._open: dict[Path, tuple] = {}  # temporary path -> (container, stream)

    def frame(self, stream: int, path: Path, image: np.ndarray, index: int) -> None:
        """Frame `index` (0, 1, ... in order) of the video being written at `path`; (H, W, 3) uint8 RGB."""
        import av

        if path not in self._open:
            container = av.open(str(path), "w")
            video = container.add_stream("libx264", rate=self.fps, options=dict(VIDEO_OPTIONS))
            video.height, video.width = image.shape[:2]
            video.pix_fmt = "yuv420p"
            if self.threads:
                video.codec_context.thread_count = self.threads
            self._open[path] = (container, video)
        container, video = self._open[path]
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
        frame.pts = index
        for packet in video.encode(frame):
            container.mux(packet)

    def finish(self, stream: int, path: Path, final_path: Path) -> None:
        """Flush and close the video at `path` and move it to `final_path`."""
        container, video = self._open.pop(path)
        for packet in video.encode():
            container.mux(packet)
        container.close()
        final_path.parent.mkdir(parents=True, exist_ok=True)
        path.rename(final_path)

    def drop(self, stream: int, path: Path) -> None:
        """Forget the video at `path` (an episode not ended when the recording stops)."""
        entry = self._open.pop(path, None)
        if entry is not None:
            entry[0].close()
        path.unlink(missing_ok=True)

    def close(self) -> None:
        """Drop what is still open; every finished video is complete."""
        for path in list(self._open):
            self.drop(0, path)


class ProcessEncoders:
    """The same, spread over `processes` worker processes; every finished video is complete once `close` returns.

    One feeding thread per worker writes its frames into its pipe (the write releases the GIL), so that the
    recording process is not held up pushing every frame through one thread (236 MB per step at 256 envs of
    640 x 480); each thread's queue holds at most `queued_frames` frames, which bounds the memory."""

    def __init__(self, fps: int, processes: int, queued_frames: int = 8):
        if processes < 1:
            raise ValueError(f"processes: {processes}; give at least 1 (or encode inline)")
        self._errors = [tempfile.TemporaryFile() for _ in range(processes)]
        self._workers = [subprocess.Popen([sys.executable, "-m", "agile.run.video_encoders", str(int(fps))],
                                          stdin=subprocess.PIPE, stderr=errors) for errors in self._errors]
        self._queues = [queue.Queue(maxsize=queued_frames) for _ in range(processes)]
        self._stopped = [False] * processes  # a worker's pipe broke: it exited, its stderr says why
        self._feeders = [threading.Thread(target=self._feed, args=(k,), daemon=True) for k in range(processes)]
        for feeder in self._feeders:
            feeder.start()

    def _feed(self, k: int) -> None:
        pipe = self._workers[k].stdin
        while (item := self._queues[k].get()) is not None:
            if self._stopped[k]:
                continue  # drain, so that the recording process never blocks on a full queue
            try:
                for part in item:
                    pipe.write(part)
            except (BrokenPipeError, OSError):
                self._stopped[k] = True

    def _send(self, stream: int, message: dict, payload: np.ndarray | None = None) -> None:
        k = stream % len(self._workers)
        if self._stopped[k]:
            raise RuntimeError(f"video encoder process {k} stopped: {self._error_text(k)}")
        parts = [json.dumps(message).encode() + b"\n"]
        if payload is not None:
            parts.append(memoryview(np.ascontiguousarray(payload, dtype=np.uint8)).cast("B"))
        self._queues[k].put(parts)

    def frame(self, stream: int, path: Path, image: np.ndarray, index: int) -> None:
        self._send(stream, {"op": "frame", "path": str(path), "shape": list(image.shape), "index": index}, image)

    def finish(self, stream: int, path: Path, final_path: Path) -> None:
        self._send(stream, {"op": "finish", "path": str(path), "final_path": str(final_path)})

    def drop(self, stream: int, path: Path) -> None:
        self._send(stream, {"op": "drop", "path": str(path)})

    def close(self) -> None:
        for q in self._queues:
            q.put(None)
        for feeder in self._feeders:
            feeder.join()
        failed = []
        for k, worker in enumerate(self._workers):
            try:
                worker.stdin.close()
            except (BrokenPipeError, OSError):
                pass
            if worker.wait() != 0:
                failed.append(f"process {k}: {self._error_text(k)}")
        for errors in self._errors:
            errors.close()
        if failed:
            raise RuntimeError("video encoding failed in " + "; ".join(failed))

    def _error_text(self, k: int) -> str:
        self._workers[k].wait()
        errors = self._errors[k]
        errors.seek(0)
        lines = errors.read().decode(errors="replace").strip().splitlines()
        return lines[-1] if lines else f"exit status {self._workers[k].returncode}"


def serve(fps: int, source=None) -> int:
    """A worker: encode the messages read from `source` (stdin) until it closes; the worker process's exit status
    (1: a video failed, its error the last line on stderr). One encoder thread: the parallelism is across
    processes."""
    source = source or sys.stdin.buffer
    encoders = InlineEncoders(fps, threads=1)
    while line := source.readline():
        message = json.loads(line)
        path = Path(message["path"])
        try:
            _serve_one(encoders, message, path, source)
        except Exception as err:  # the last line of stderr is what the recording process reports
            print(f"{path}: {type(err).__name__}: {err}", file=sys.stderr, flush=True)
            return 1
    encoders.close()
    return 0


def _serve_one(encoders: InlineEncoders, message: dict, path: Path, source) -> None:
    if message["op"] == "frame":
        shape = tuple(message["shape"])
        size = int(np.prod(shape))
        data = source.read(size)
        if len(data) != size:
            raise EOFError(f"{path}: a frame of {size} bytes ended after {len(data)}")
        encoders.frame(0, path, np.frombuffer(data, np.uint8).reshape(shape), message["index"])
    elif message["op"] == "finish":
        encoders.finish(0, path, Path(message["final_path"]))
    else:
        encoders.drop(0, path)


if __name__ == "__main__":
    sys.exit(serve(int(sys.argv[1])))
