"""The demo's stereoscopic-zoom shots are the example shot files (at a smaller image size)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from vergence.report.demo_rigs import DEMO_RENDER, DEMO_SHOTS, demo_shot

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "shots"


@pytest.mark.parametrize("kind", ["quadri", "tri"])
def test_demo_shots_are_the_stadium_examples(kind):
    example = json.loads((EXAMPLES / f"stadium-{kind}.json").read_text())
    assert example == DEMO_SHOTS[kind]
    shot = demo_shot(kind)
    assert (shot.camera.width, shot.camera.height) == DEMO_RENDER[kind][:2]
    assert shot.rig == kind
    shot.plan()  # plans without error
