"""The dino collection, triangulated once for the whole session (about 3 s on one core)."""

from __future__ import annotations

import time

import pytest

from vergence.stereospace import load_collection


@pytest.fixture(scope="session")
def dino(shared_data):
    """``(collection, seconds)``: dino loaded and triangulated with the default settings."""
    folder = shared_data / "collections" / "dino"
    start = time.perf_counter()
    col = load_collection(folder / "dino_par.txt", images=folder)
    return col, time.perf_counter() - start
