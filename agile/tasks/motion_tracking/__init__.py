"""Motion tracking tasks: a policy follows a reference motion (BeyondMimic)."""
