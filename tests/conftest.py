"""Shared fixtures: the real data in ../shared/data (tests skip with a reason when it is missing)."""

from __future__ import annotations

import os
from pathlib import Path

# Before anything imports Numba's threading layer: OpenMP threads that spin while they wait steal the
# two shared cores the suite runs on (the ``vergence`` command sets the same default; the library
# itself leaves the environment alone). A policy set by the user wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path to ``../shared/data``; skips the test when the folder is not beside the checkout."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared test data not found at {SHARED_DATA} (see shared/data/SOURCES.md)")
    return SHARED_DATA


# CI runs the property tests with a fixed seed so that a landing never depends on the draw; locally
# hypothesis explores new examples on every run.
if os.environ.get("CI"):
    settings.register_profile("ci", derandomize=True, print_blob=True)
    settings.load_profile("ci")
