"""The workbench's uploads (issue 13): the type by content, limits in bytes and pixels, nothing decoded past them."""

from __future__ import annotations

import io
import struct
import warnings
import zlib

import numpy as np
import pytest

pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
pytest.importorskip("httpx", reason="FastAPI's test client needs httpx: pip install 'vergence[web]'")

with warnings.catch_warnings():
    # Starlette >= 1.x asks for httpx2 and warns once, at import, when it finds httpx (the web extra's).
    warnings.filterwarnings("ignore", message="Using `httpx` with `starlette.testclient` is deprecated",
                            category=UserWarning)
    from fastapi.testclient import TestClient

from vergence.io import write_image, write_pfm
from vergence.web import MAX_JSON_BODY, MAX_UPLOAD_BYTES, MAX_UPLOAD_PIXELS, create_app
from web_checks import refused as _refused


@pytest.fixture
def app():
    return create_app()


@pytest.fixture
def client(app):
    with TestClient(app, base_url="http://127.0.0.1") as c:
        yield c


def _file(tmp_path, name: str, image) -> bytes:  # noqa: ANN001
    path = tmp_path / name
    (write_pfm if name.endswith(".pfm") else write_image)(path, image)
    return path.read_bytes()


def _post(client, data: bytes, content_type: str = "image/png", name: str = ""):  # noqa: ANN001, ANN202
    return client.post("/api/uploads", content=data, headers={"content-type": content_type}, params={"name": name})


def _chunk(kind: bytes, payload: bytes) -> bytes:
    return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))


def test_the_limits():
    assert MAX_UPLOAD_BYTES == 64 * 2**20 and MAX_UPLOAD_PIXELS == 40_000_000
    assert MAX_UPLOAD_BYTES > MAX_JSON_BODY


def test_a_png_is_stored_with_its_metadata(client, tmp_path):
    rgb = np.linspace(0, 1, 5 * 7 * 3).reshape(5, 7, 3)
    response = _post(client, _file(tmp_path, "a.png", rgb), name="holiday.png")
    assert response.status_code == 201, response.text
    meta = response.json()
    assert {k: meta[k] for k in ("kind", "width", "height", "channels", "dtype", "name")} == {
        "kind": "png", "width": 7, "height": 5, "channels": 3, "dtype": "uint8", "name": "holiday.png"}
    assert client.get(f"/api/uploads/{meta['id']}").json() == meta
    assert str(tmp_path) not in response.text and "path" not in meta
    write_image(tmp_path / "b.png", np.full((3, 4), 0.5), bit_depth=16)
    grey16 = _post(client, (tmp_path / "b.png").read_bytes())
    assert {k: grey16.json()[k] for k in ("width", "height", "channels", "dtype")} == {
        "width": 4, "height": 3, "channels": 1, "dtype": "uint16"}


def test_a_pfm_depth_map_with_unknown_pixels_is_accepted(client, tmp_path):
    depth = np.array([[1.0, np.nan, 3.0], [np.inf, 2.0, 4.0]], np.float32)
    meta = _post(client, _file(tmp_path, "d.pfm", depth), "image/x-portable-floatmap").json()
    assert {k: meta[k] for k in ("kind", "width", "height", "channels", "dtype")} == {
        "kind": "pfm", "width": 3, "height": 2, "channels": 1, "dtype": "float32"}


def test_an_npy_map_is_accepted_past_the_json_body_limit(client, app):
    buffer = io.BytesIO()
    np.save(buffer, np.zeros((512, 1024), np.float32))  # 2 MiB: over MAX_JSON_BODY, which is for JSON only
    data = buffer.getvalue()
    assert len(data) > MAX_JSON_BODY
    response = _post(client, data, "application/octet-stream", name="depth.npy")
    assert response.status_code == 201, response.text
    meta = response.json()
    assert {k: meta[k] for k in ("kind", "width", "height", "channels", "dtype", "bytes")} == {
        "kind": "npy", "width": 1024, "height": 512, "channels": 1, "dtype": "float32", "bytes": len(data)}
    assert app.state.uploads.get(meta["id"]).path.read_bytes() == data


def test_content_wins_over_name_and_type(client, app, tmp_path):
    jpeg = _file(tmp_path, "photo.jpg", np.full((8, 6, 3), 0.5))
    meta = _post(client, jpeg, "image/png", name="photo.png").json()
    assert meta["kind"] == "jpeg" and meta["name"] == "photo.png" and (meta["width"], meta["height"]) == (6, 8)
    assert app.state.uploads.get(meta["id"]).path.suffix == ".jpg"


def test_too_many_bytes_is_413_declared_or_streamed(client, app):
    app.state.uploads.max_bytes = 1000
    data = b"\x89PNG\r\n\x1a\n" + bytes(2000)
    assert _refused(_post(client, data), 413) == \
        "upload too large: 2008 bytes; the limit is 1000 bytes (MAX_UPLOAD_BYTES)"

    def chunks():  # no Content-Length: counted as it arrives
        for i in range(0, len(data), 100):
            yield data[i:i + 100]

    streamed = client.post("/api/uploads", content=chunks(), headers={"content-type": "image/png"})
    assert _refused(streamed, 413) == "upload too large: more than 1000 bytes (MAX_UPLOAD_BYTES)"
    assert list((app.state.workdir / "uploads").iterdir()) == []  # nothing kept


def test_too_many_pixels_is_413_without_decoding(client, app, monkeypatch):
    import vergence.web.uploads as uploads

    def never(*args):  # noqa: ANN002, ANN202
        raise AssertionError("decoded past the pixel limit")

    monkeypatch.setattr(uploads, "_decode", never)
    ihdr = struct.pack(">IIBBBBB", 100_000, 100_000, 8, 2, 0, 0, 0)
    bomb = b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", zlib.compress(b"")) + _chunk(b"IEND", b"")
    assert _refused(_post(client, bomb), 413) == (
        "image too large: its header declares 100000 x 100000 = 10,000,000,000 pixels; the limit is 40,000,000 "
        "(MAX_UPLOAD_PIXELS)")
    pfm = b"PF\n20000 20000\n-1.0\n" + bytes(64)
    assert "20000 x 20000" in _refused(_post(client, pfm, "image/x-portable-floatmap"), 413)
    assert list((app.state.workdir / "uploads").iterdir()) == []


@pytest.mark.parametrize("data, message", [
    (b"GIF89a\x01\x00\x01\x00",
     "unsupported upload: content is not PNG, JPEG, PFM or NPY (first bytes b'GIF89a\\x01\\x00')"),
    (b"", "the upload is empty: send the file as the request body"),
    (b"\x89PNG\r\n\x1a\n\x00", "unsupported upload: PNG header is truncated (no IHDR chunk)"),
    (b"PF\nnot a header", "unsupported upload: PFM header is malformed (expected 'PF' or 'Pf', width height, scale)"),
])
def test_unknown_or_broken_content_is_422(client, data, message):
    assert _refused(_post(client, data), 422) == message


def test_corrupt_data_is_422_without_a_server_path(client, app, tmp_path):
    png = _file(tmp_path, "a.png", np.zeros((16, 16)))
    message = _refused(_post(client, png[:-20]), 422)
    assert message.startswith("the PNG upload is not valid: ") and str(app.state.workdir) not in message
    pfm = b"Pf\n4 4\n-1.0\n" + bytes(10)  # 64 bytes of data announced
    assert _refused(_post(client, pfm, "image/x-portable-floatmap"), 422).startswith("the PFM upload is not valid: ")
    assert list((app.state.workdir / "uploads").iterdir()) == []


def test_a_content_type_outside_the_list_is_415(client, tmp_path):
    png = _file(tmp_path, "a.png", np.zeros((2, 2)))
    assert _refused(_post(client, png, "text/plain"), 415).startswith(
        "Content-Type must be one of image/png, image/jpeg, image/x-portable-floatmap, application/octet-stream")
    assert _refused(client.post("/api/uploads", files={"file": ("a.png", png, "image/png")}), 415).startswith(
        "Content-Type must be one of")  # multipart is not read: the body is the file
    assert _refused(client.post("/api/uploads", content=png), 415).endswith("got 'none' (send the file itself as the body)")


def test_unknown_upload_is_404(client):
    assert _refused(client.get("/api/uploads/nope"), 404).startswith("unknown upload id 'nope'")


def test_the_oldest_upload_is_deleted_past_the_bound(client, app, tmp_path):
    app.state.uploads.max_uploads = 1
    png = _file(tmp_path, "a.png", np.zeros((2, 2)))
    first = _post(client, png).json()
    path = app.state.uploads.get(first["id"]).path
    second = _post(client, png).json()
    assert second["id"] != first["id"] and not path.exists()
    _refused(client.get(f"/api/uploads/{first['id']}"), 404)


def test_shutdown_removes_the_temporary_folder(tmp_path):
    app = create_app()
    with TestClient(app, base_url="http://127.0.0.1") as c:
        meta = _post(c, _file(tmp_path, "a.png", np.zeros((2, 2)))).json()
        stored = app.state.uploads.get(meta["id"]).path
        assert stored.is_file() and stored.is_relative_to(app.state.workdir)
    assert not app.state.workdir.exists()
