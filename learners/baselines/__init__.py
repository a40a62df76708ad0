"""Exact baselines that know the arm and cameras (for comparison, never for learning)."""
