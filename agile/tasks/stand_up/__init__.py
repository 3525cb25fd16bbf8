"""Stand-up tasks: rise from any fall, starting from a fallen-state dataset collected before learning."""

from agile.tasks.stand_up import g1, t1  # noqa: F401
