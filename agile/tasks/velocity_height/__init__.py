"""Velocity-Height tasks: walk at a commanded velocity and base height (AGILE `locomotion_height`)."""
