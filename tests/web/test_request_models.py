"""Every request body of the pages and jobs refuses JSON true/false for a number (found by the sweep's
web kind, tools/sweep/web_cases.py: `"width": true` started a render of width 1), naming the field."""

from __future__ import annotations

import warnings

import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.web import create_app
from vergence.web._models import RequestModel, _numeric
from web_checks import refused


@pytest.mark.parametrize(("path", "body", "field"), [
    ("/api/jobs/render", {"scene": "scene:tabletop", "width": True, "height": 2, "depth": 0, "samples": 1}, "width"),
    ("/api/jobs/specular", {"scene": "scene:glasses", "width": 8, "height": 6, "samples": False}, "samples"),
    ("/api/jobs/synthesize", {"example_height": True}, "example_height"),
    ("/api/jobs/rig", {"shot": {}, "width": 16, "supersample": True}, "supersample"),
    ("/api/stereospace/nope/move", {"state": {"region": [0, 0], "li": True, "lj": 1}, "pan": 0.1, "zoom": 0},
     "state[li]"),
    ("/api/stereospace/nope/move", {"state": {"region": [0, 0], "li": 0, "lj": 1}, "pan": False, "zoom": 0}, "pan"),
])
def test_a_boolean_is_no_number_in_any_body(path, body, field):
    with TestClient(create_app(), base_url="http://127.0.0.1") as client:
        message = refused(client.post(path, json=body), 422)
    assert message.startswith(f"{field}: expected a number (got "), message


def test_which_fields_are_numbers():
    assert _numeric(int) and _numeric(float) and _numeric(float | None) and _numeric(int | str)
    assert not _numeric(bool) and not _numeric(str) and not _numeric(bool | int) and not _numeric(list[float])


def test_a_flag_still_takes_a_boolean():
    class Body(RequestModel):
        level: int = 0
        fast: bool = False

    assert Body.model_validate({"fast": True}).fast is True
    with pytest.raises(ValueError, match="expected a number"):
        Body.model_validate({"level": True})
