"""Which agent acts at which physics step: the schedule of a world whose agents have different control periods."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Slot:
    """A moment in the hyperperiod at which at least one agent acts."""

    physics_step: int
    """Physics steps since the start of the hyperperiod."""
    agents: tuple[str, ...]
    """The agents whose period ends here: they are rewarded and observe, then act."""
    ticks_to_next: int
    """Ticks (of `Schedule.tick_steps` physics steps) until the next slot."""


class Schedule:
    """Agents with control periods of `periods[name]` physics steps, in one world.

    The world advances in ticks of the periods' greatest common divisor; the pattern repeats every hyperperiod
    (their least common multiple). A slot is a tick at which some agent acts; at the first slot of the
    hyperperiod every agent acts, so episodes start and end there. Between its slots an agent's last targets
    hold while its actuators run at the physics rate.
    """

    def __init__(self, periods: dict[str, int]):
        if not periods:
            raise ValueError("a schedule needs at least one agent")
        for name, period in periods.items():
            if not isinstance(period, int) or isinstance(period, bool) or period < 1:
                raise ValueError(f"agent '{name}': control period must be a positive number of physics steps, "
                                 f"got {period!r}")
        self.periods = dict(periods)
        self.tick_steps = math.gcd(*periods.values())
        self.hyperperiod_steps = math.lcm(*periods.values())
        self.num_ticks = self.hyperperiod_steps // self.tick_steps
        """Ticks per hyperperiod."""
        acting = [(t * self.tick_steps, tuple(a for a, p in periods.items() if (t * self.tick_steps) % p == 0))
                  for t in range(self.num_ticks)]
        acting_ticks = [t for t, (_, agents) in enumerate(acting) if agents]
        self.slots: list[Slot] = []
        for i, tick in enumerate(acting_ticks):
            next_tick = acting_ticks[i + 1] if i + 1 < len(acting_ticks) else self.num_ticks
            self.slots.append(Slot(acting[tick][0], acting[tick][1], next_tick - tick))

    def acting_at(self, physics_step: int) -> tuple[str, ...]:
        """The agents acting at a physics step (counted from an episode start)."""
        step = physics_step % self.hyperperiod_steps
        return tuple(a for a, p in self.periods.items() if step % p == 0)

    def describe(self) -> str:
        return ", ".join(f"step {s.physics_step}: {'+'.join(s.agents)}" for s in self.slots)
