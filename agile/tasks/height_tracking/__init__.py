"""HeightTracking-G1: sit down, lie down and stand up on command, from fallen and standing starts (AGILE v1.3); built
on the stand-up family's fallen-state resets and terms."""
