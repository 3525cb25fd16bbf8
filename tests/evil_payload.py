"""What a malicious checkpoint carries: an object whose unpickling runs code (here: writes a marker file)."""

from pathlib import Path


def write_marker(path: str) -> None:
    Path(path).write_text("code from the checkpoint ran")


class Payload:
    def __init__(self, marker_path: str):
        self.marker_path = marker_path

    def __reduce__(self):
        return write_marker, (self.marker_path,)
