"""Stand-up tasks: rise from any fall, starting from a fallen-state dataset collected before learning."""
