"""Shared pytest setup: headless plotting."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
