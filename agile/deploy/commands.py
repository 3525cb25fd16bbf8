"""The command a deployed policy gets each control period, and where it comes from: a fixed one (`--command`), lines
typed on the keyboard, the G1's wireless remote, or a DDS topic of `geometry_msgs/Twist` (ROS 2's `cmd_vel`).

Every value is clipped to the ranges the policy was trained on (a policy commanded outside them does what nobody
tested); a streaming source (the topic) that falls silent for `stream_timeout_s` leaves the robot standing (zero
velocity) until it speaks again. Each such change is an event: printed by the caller and kept for the log."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np

RANGE_KEYS = {"lin_vel_x": "lin_vel_x", "lin_vel_y": "lin_vel_y", "ang_vel_z": "ang_vel_z",
              "base_height": "base_height_m"}
"""Command element -> its range's key in the policy's command term."""


def command_ranges(commands: dict, elements: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of each command element, from the policy's (first) command term's ranges."""
    ranges = next(iter(commands.values()), {}).get("ranges", {})
    bounds = [ranges.get(RANGE_KEYS[e], [-np.inf, np.inf]) for e in elements]
    return np.array([min(b) for b in bounds], dtype=float), np.array([max(b) for b in bounds], dtype=float)


@dataclass(frozen=True)
class CommandEvent:
    time_s: float
    """time.monotonic()."""
    text: str


class PolicyCommand:
    """The command, set by its sources (any thread) and read once per control period (`__call__(state)`).

    `initial` is the whole command (velocity, and height where the policy takes one); `set` replaces it or its first
    values (the keyboard); `per_state` reads the velocity from each state (the remote); `set_velocity_stream` is a
    streaming source's velocity (the topic), zeroed when older than `stream_timeout_s`. Non-finite values are refused
    and counted, clipped ones counted."""

    def __init__(self, *, initial: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                 stream_timeout_s: float = 0.5, per_state=None, on_event=None, clock=time.monotonic):
        self.lower, self.upper = lower, upper
        self.per_state = per_state
        """state -> (vx, vy, wz) each period, e.g. the G1 remote's sticks; clipped, not counted."""
        self.value = np.clip(np.asarray(initial, dtype=float), lower, upper)
        self.stream_timeout_s = stream_timeout_s
        self.on_event = on_event
        self.clock = clock
        self.lock = threading.Lock()
        self.stream_velocity: np.ndarray | None = None
        self.stream_s: float | None = None
        self.stream_silent = False
        self.events: list[CommandEvent] = []
        self.clipped = 0
        self.refused = 0
        self.stream_messages = 0

    def _event(self, text: str) -> None:
        event = CommandEvent(self.clock(), text)
        self.events.append(event)
        if self.on_event is not None:
            self.on_event(event)

    def _clip(self, values: np.ndarray) -> np.ndarray:
        clipped = np.clip(values, self.lower[:len(values)], self.upper[:len(values)])
        self.clipped += bool(np.any(clipped != values))
        return clipped

    def set(self, values, source: str) -> bool:
        """Replace the command's first len(values) elements (VX VY WZ, or all of them with the height). False, and
        nothing changed, for a wrong length or a non-finite value."""
        values = np.asarray(values, dtype=float)
        with self.lock:
            if not 3 <= len(values) <= len(self.value) or not np.all(np.isfinite(values)):
                self.refused += 1
                return False
            self.value = np.concatenate([self._clip(values), self.value[len(values):]])
            text = " ".join(f"{v:g}" for v in self.value)
        self._event(f"{source}: command {text}")
        return True

    def set_velocity_stream(self, vx: float, vy: float, wz: float) -> None:
        """A streaming source's newest velocity (called from a DDS listener's thread)."""
        values = np.array([vx, vy, wz], dtype=float)
        with self.lock:
            self.stream_messages += 1
            if not np.all(np.isfinite(values)):
                self.refused += 1
                return
            self.stream_velocity, self.stream_s = self._clip(values), self.clock()

    def __call__(self, state=None) -> np.ndarray:
        """The command for this period; `state` (a RobotState) feeds `per_state`."""
        with self.lock:
            out = self.value.copy()
            velocity, stream_s = self.stream_velocity, self.stream_s
        if self.per_state is not None and state is not None:
            out[:3] = np.clip(self.per_state(state), self.lower[:3], self.upper[:3])
        if stream_s is None:
            return out
        silent = self.clock() - stream_s > self.stream_timeout_s
        if silent != self.stream_silent:
            self.stream_silent = silent
            self._event(f"command topic silent for more than {self.stream_timeout_s} s: standing" if silent
                        else "command topic speaking again")
        out[:3] = 0.0 if silent else velocity
        return out

    def summary(self) -> dict:
        return {"final": self.value.tolist(), "clipped": self.clipped, "refused": self.refused,
                "stream_messages": self.stream_messages,
                "events": [{"time_s": e.time_s, "event": e.text} for e in self.events]}


def parse_keyboard_line(line: str) -> list[float] | None:
    """A typed command: three or four numbers (VX VY WZ [HEIGHT]); None for anything else."""
    try:
        values = [float(v) for v in line.replace(",", " ").split()]
    except ValueError:
        return None
    return values if len(values) >= 3 else None
