"""Studies built on the harness: re-adaptation after a change (with the re-calibrated oracle),
sweeps (grid, Ray runner, plots), the map against deep RL, and rendered sensing's accuracy."""
