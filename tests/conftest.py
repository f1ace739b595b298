"""Shared test set-up: a headless matplotlib and the project root for case/study files."""
from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")
