"""The run harness: trials, training with checkpoints, run folders, stopping on signals,
held-out evaluation, plots, videos, and path tracking episodes.

Layering: builds on the environments and the learners; nothing below imports it.
"""
