"""``vergence serve``: the workbench (a local page and its JSON API, :mod:`vergence.web`)."""

from __future__ import annotations

import ipaddress
import os
import secrets
import socket
from pathlib import Path

import typer

from vergence.cli._app import app, console

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "is_loopback", "serve"]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765


def is_loopback(host: str) -> bool:
    """Whether ``host`` names this machine only: ``localhost`` or a loopback address (127.0.0.0/8, ::1)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _listen(host: str, port: int) -> socket.socket:
    """A listening socket on ``host:port``; a busy port or an unknown host is one line, exit 2."""
    try:
        family = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0][0]
        return socket.create_server((host.strip("[]"), port), family=family, backlog=128)
    except OSError as exc:
        reason = os.strerror(exc.errno) if exc.errno else str(exc)
        raise OSError(f"cannot listen on {host}:{port}: {reason[:1].lower() + reason[1:]}") from None


@app.command("serve")
def serve(
    host: str = typer.Option(DEFAULT_HOST, "--host", help="Address to listen on (loopback unless --allow-remote)."),
    port: int = typer.Option(DEFAULT_PORT, "--port", min=0, max=65535, help="Port to listen on (0: any free port)."),
    data: list[Path] = typer.Option([], "--data", help="Folder of collections and scenes the page may open; repeat."),
    allow_remote: bool = typer.Option(False, "--allow-remote", help="Allow a --host other machines can reach."),
) -> None:
    """Run the workbench: a local page and its JSON API; Ctrl-C stops it.

    Only requests whose Host is a loopback name or the host given are served (DNS rebinding); with
    --allow-remote and a non-loopback host, the printed URL carries a token every request needs.
    """
    if not is_loopback(host) and not allow_remote:
        raise ValueError(f"--host {host} is not a loopback address: anyone who reaches it could use the workbench; "
                         f"add --allow-remote to serve it anyway")  # fmt: skip
    from vergence.web.data import check_data_dirs

    try:
        check_data_dirs(data)
    except ValueError as exc:
        raise ValueError(f"--data: {exc}") from None
    try:
        import uvicorn

        from vergence.web import create_app
    except ImportError as exc:
        raise ValueError(f"vergence serve needs the web extra: pip install 'vergence[web]' ({exc})") from None
    from vergence.cli._malloc import keep_freed_memory

    keep_freed_memory(os.environ)  # each request's images: freed blocks reused, not faulted in again
    sock = _listen(host, port)
    try:
        address, bound = sock.getsockname()[:2]
        # served: the loopback names, the host given and the address bound; reachable from other
        # machines, every request must also carry a token (printed once, as Jupyter does)
        token = None if is_loopback(host) else secrets.token_urlsafe(32)
        application = create_app(data, allowed_hosts=[host, address], token=token, warm_kernels=True)
        shown = f"[{host.strip('[]')}]" if ":" in host else host
        query = f"?token={token}" if token else ""
        console.print(f"Vergence workbench at http://{shown}:{bound}/{query} (Ctrl-C stops it)", highlight=False,
                      soft_wrap=True)
        server = uvicorn.Server(uvicorn.Config(application, log_level="warning", ws="none"))
        server.run(sockets=[sock])
    finally:
        sock.close()
