"""Reference motions shipped with agile (scripts/make_demo_motions.py writes them)."""
