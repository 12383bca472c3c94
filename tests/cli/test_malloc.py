"""glibc's malloc thresholds set by ``vergence serve`` (vergence.cli._malloc): freed images reused."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
import textwrap

import pytest

from vergence.cli._malloc import keep_freed_memory

GLIBC = sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc"


def test_the_user_s_thresholds_win():
    assert keep_freed_memory({"MALLOC_MMAP_THRESHOLD_": "131072"}) is False
    assert keep_freed_memory({"MALLOC_TRIM_THRESHOLD_": "0"}) is False


# Kermit's 640 x 480 anaglyph pair, as the workbench renders one per request: page faults a pair.
_PAIRS = """
import resource, sys
from pathlib import Path
from vergence.cli._malloc import keep_freed_memory
from vergence.stereospace import PreparedCollection, StereoState, load_collection, stereo_pair
kept = sys.argv[2] == "kept" and keep_freed_memory({})
folder = Path(sys.argv[1]) / "collections" / "kermit"
prepared = PreparedCollection(load_collection(folder / "bundle.out", images=folder))
state = StereoState((0, 1), 0.5, 0.5)
for _ in range(2):
    stereo_pair(prepared, state, layout="anaglyph")
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(4):
    stereo_pair(prepared, state, layout="anaglyph")
print(kept, (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 4)
"""


@pytest.mark.skipif(not GLIBC, reason="glibc's mallopt")
def test_a_pair_s_images_are_reused_not_faulted_in_again(shared_data):
    # Measured: 1,769 page faults a pair with glibc's defaults (the heap's top handed back after each
    # pair, 7 MB), 0-1 with the thresholds set.
    env = {**os.environ, "OMP_WAIT_POLICY": "PASSIVE"}
    env.pop("MALLOC_MMAP_THRESHOLD_", None)
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(_PAIRS), str(shared_data), "kept"], env=env,
                         capture_output=True, text=True, check=True).stdout.split()  # fmt: skip
    assert out[0] == "True"
    assert float(out[1]) < 50
