"""``vergence serve``: its refusals are one line and exit code 2, and it starts no server for them."""

from __future__ import annotations

import importlib
import re
import socket
import sys

import pytest

from vergence.cli import main


@pytest.mark.parametrize("host", ["0.0.0.0", "192.168.1.5", "::", "example.com"])
def test_a_host_other_machines_reach_needs_allow_remote(capsys, host):
    assert main(["serve", "--host", host]) == 2
    assert capsys.readouterr().err == (f"error: --host {host} is not a loopback address: anyone who reaches it "
                                       f"could use the workbench; add --allow-remote to serve it anyway\n")


@pytest.mark.parametrize("host, loopback", [("127.0.0.1", True), ("127.1.2.3", True), ("localhost", True),
                                            ("::1", True), ("[::1]", True), ("0.0.0.0", False), ("::", False),
                                            ("10.0.0.1", False), ("localhost.example.com", False)])
def test_is_loopback(host, loopback):
    from vergence.cli.serve import is_loopback

    assert is_loopback(host) is loopback


def test_a_data_folder_must_exist_and_be_a_folder(capsys, tmp_path):
    assert main(["serve", "--data", str(tmp_path), "--data", str(tmp_path / "nope")]) == 2
    assert capsys.readouterr().err == f"error: --data: data folder {tmp_path / 'nope'} does not exist\n"
    (tmp_path / "file.txt").write_text("")
    assert main(["serve", "--data", str(tmp_path / "file.txt")]) == 2
    assert capsys.readouterr().err == f"error: --data: data folder {tmp_path / 'file.txt'} is not a folder\n"


def test_a_port_out_of_range_is_refused(capsys):
    assert main(["serve", "--port", "70000"]) == 2
    assert capsys.readouterr().err == "error: --port: must be <= 65535 (got 70000)\n"


def test_without_the_web_extra_it_says_what_to_install(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "uvicorn", None)  # `import uvicorn` now fails as if not installed
    assert main(["serve"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: vergence serve needs the web extra: pip install 'vergence[web]'")
    assert len(err.splitlines()) == 1


def test_importing_vergence_web_without_fastapi_names_the_extra(monkeypatch):
    for name in [m for m in sys.modules if m == "vergence.web" or m.startswith("vergence.web.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "fastapi", None)
    with pytest.raises(ImportError, match=re.escape("pip install 'vergence[web]'")):
        importlib.import_module("vergence.web")


def test_a_busy_port_is_one_line(capsys):
    pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
    pytest.importorskip("uvicorn", reason="the web extra is not installed: pip install 'vergence[web]'")
    with socket.create_server(("127.0.0.1", 0)) as busy:
        port = busy.getsockname()[1]
        assert main(["serve", "--port", str(port)]) == 2
    assert capsys.readouterr().err == f"error: cannot listen on 127.0.0.1:{port}: address already in use\n"


def test_it_prints_the_url_then_runs_uvicorn(capsys, monkeypatch, tmp_path):
    pytest.importorskip("fastapi", reason="the web extra is not installed: pip install 'vergence[web]'")
    uvicorn = pytest.importorskip("uvicorn", reason="the web extra is not installed: pip install 'vergence[web]'")
    ran = []

    def run(self, sockets=None):  # the server itself: tests/web/test_api.py starts a real one
        ran.append((self.config.log_level, sockets[0].getsockname()))

    monkeypatch.setattr(uvicorn.Server, "run", run)
    assert main(["serve", "--port", "0", "--data", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    m = re.fullmatch(r"Vergence workbench at http://127\.0\.0\.1:(\d+)/ \(Ctrl-C stops it\)\n", out)
    assert m is not None, out
    assert ran == [("warning", ("127.0.0.1", int(m[1])))]
