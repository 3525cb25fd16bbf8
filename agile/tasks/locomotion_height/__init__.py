"""Velocity and base-height tasks (AGILE `locomotion_height`)."""
