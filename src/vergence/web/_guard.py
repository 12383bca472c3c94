"""The workbench's guards: ASGI middlewares that refuse a request before any route sees it.

Three rules, outermost first (:func:`add_guards` installs them in this order):

1. :class:`HostGuard` (DNS rebinding): the ``Host`` header must name this machine's loopback
   (``localhost``, 127.0.0.0/8, ``[::1]``) or an address the server was told it serves
   (``vergence serve`` passes the host it binds; an address of all interfaces, ``0.0.0.0`` or
   ``::``, stands for any IP address literal). A page whose name an attacker points at 127.0.0.1
   sends its own name as ``Host`` and is refused, 400, on every path.
2. :class:`TokenGuard` (``--allow-remote``): when the app has a token, every request carries it:
   ``?token=...`` in the URL (as the one ``vergence serve`` prints; the answer then sets an
   HttpOnly, SameSite=Strict cookie, so the page's own requests carry it), that cookie, or
   ``Authorization: Bearer ...``; 401 otherwise. Loopback serving has no token.
3. :class:`OriginGuard` (cross-site requests): a state-changing method (POST, PUT, PATCH, DELETE)
   is refused, 403, when ``Sec-Fetch-Site`` says ``cross-site`` or ``same-site`` (another origin),
   or when an ``Origin`` header is present and is not ``http(s)://`` the request's own ``Host``
   (another port is another origin). A body-carrying method (POST, PUT, PATCH) must say
   ``Content-Type: application/json``, 415 otherwise, a missing type included (``POST /api/uploads``
   checks its own list, :data:`vergence.web.uploads.UPLOAD_CONTENT_TYPES`, also 415): a
   page of another site can send ``text/plain`` or no type without asking the server first (a
   "simple" request, no CORS preflight), never ``application/json``.

Every refusal is the API's ``{"error": "<one line>"}`` (:func:`vergence.web._errors.refusal`).
"""

from __future__ import annotations

import ipaddress
import secrets
from collections.abc import Iterable
from http.cookies import SimpleCookie
from urllib.parse import parse_qs, urlsplit

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from vergence.web._errors import MAX_SHOWN, refusal

__all__ = ["LOOPBACK_NAMES", "TOKEN_COOKIE", "HostGuard", "OriginGuard", "TokenGuard", "add_guards", "host_allowed"]

#: Host names that are always this machine (besides the addresses of 127.0.0.0/8 and ::1).
LOOPBACK_NAMES = frozenset({"localhost"})

#: The cookie that carries the token after a request with ``?token=``.
TOKEN_COOKIE = "vergence-token"

_STATE_CHANGING = frozenset({"POST", "PUT", "PATCH", "DELETE"})
_WITH_BODY = frozenset({"POST", "PUT", "PATCH"})
_UPLOADS = "/api/uploads"  # the route with its own body types (vergence.web.uploads.UPLOAD_CONTENT_TYPES)


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", ()):
        if key.lower() == name:
            return value.decode("latin-1")
    return None


def _shown(value: str) -> str:
    return repr(value if len(value) <= MAX_SHOWN else value[: MAX_SHOWN - 3] + "...")


def _split_host(host: str) -> tuple[str, int | None]:
    """``name[:port]`` or ``[v6][:port]`` -> (name in lower case without a final dot or brackets, port)."""
    host = host.strip().lower()
    if host.startswith("["):
        name, _, rest = host[1:].partition("]")
        port = rest.removeprefix(":")
    else:
        name, _, port = host.partition(":") if host.count(":") == 1 else (host, "", "")
    return name.removesuffix("."), int(port) if port.isdigit() else None


def _unspecified(host: str) -> bool:
    try:
        return ipaddress.ip_address(host.strip("[]")).is_unspecified
    except ValueError:
        return False


def host_allowed(name: str, allowed: Iterable[str] = ()) -> bool:
    """Whether a request's host name (no port) is served: a loopback name or address, or one of ``allowed``.

    An unspecified address in ``allowed`` (``0.0.0.0``, ``::``: a server bound to every interface)
    admits any IP address literal, never a name: a rebinding attack needs a name it controls.
    """
    name = name.lower().strip("[]").removesuffix(".")
    if name in LOOPBACK_NAMES:
        return True
    try:
        address = ipaddress.ip_address(name)
    except ValueError:
        address = None
    if address is not None and address.is_loopback:
        return True
    for other in allowed:
        if other.lower().strip("[]").removesuffix(".") == name or (address is not None and _unspecified(other)):
            return True
    return False


class HostGuard:
    """Refuse (400) a request whose ``Host`` is not served (:func:`host_allowed`), on every path."""

    def __init__(self, app: ASGIApp, *, allowed: Iterable[str] = ()) -> None:
        self.app, self.allowed = app, tuple(allowed)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] in ("http", "websocket"):
            host = _header(scope, b"host")
            if host is None:
                await refusal(400, "the request has no Host header")(scope, receive, send)
                return
            name, _ = _split_host(host)
            if not host_allowed(name, self.allowed):
                served = ", ".join(dict.fromkeys(["localhost", "127.0.0.1", "[::1]", *(
                    "any IP address" if _unspecified(a) else a for a in self.allowed)]))
                await refusal(400, f"Host {_shown(host)} is not served here; this workbench answers to {served} "
                                   "(a foreign name is how DNS rebinding reaches a local server)")(
                    scope, receive, send)  # fmt: skip
                return
        await self.app(scope, receive, send)


class TokenGuard:
    """Refuse (401) a request without the app's token (query ``token=``, its cookie, or a Bearer header).

    A request that shows it in the query gets the cookie :data:`TOKEN_COOKIE` (HttpOnly,
    SameSite=Strict, path ``/``), so the page's later requests need not repeat it.
    """

    def __init__(self, app: ASGIApp, *, token: str) -> None:
        if not token:
            raise ValueError("token must be a non-empty string")
        self.app, self.token = app, token

    def _matches(self, given: str | None) -> bool:
        return given is not None and secrets.compare_digest(given.encode(), self.token.encode())

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        query = parse_qs(scope.get("query_string", b"").decode("latin-1")).get("token", [None])[0]
        auth = _header(scope, b"authorization") or ""
        bearer = auth[7:].strip() if auth[:7].lower() == "bearer " else None
        cookie = SimpleCookie()
        try:
            cookie.load(_header(scope, b"cookie") or "")
        except Exception:  # noqa: BLE001 - an unparsable Cookie header carries no token
            cookie = SimpleCookie()
        stored = cookie[TOKEN_COOKIE].value if TOKEN_COOKIE in cookie else None
        if self._matches(bearer) or self._matches(stored):
            await self.app(scope, receive, send)
            return
        if not self._matches(query):
            await refusal(401, "this workbench needs its token: open the URL vergence serve printed (with "
                               "?token=...), or send Authorization: Bearer <token>")(scope, receive, send)  # fmt: skip
            return
        set_cookie = f"{TOKEN_COOKIE}={self.token}; Path=/; HttpOnly; SameSite=Strict".encode("latin-1")

        async def send_with_cookie(message: Message) -> None:
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message.get("headers", []), (b"set-cookie", set_cookie)]}
            await send(message)

        await self.app(scope, receive, send_with_cookie)


class OriginGuard:
    """Refuse a state-changing request from another origin (403) or with a body type not JSON (415)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        method = scope.get("method", "")
        if scope["type"] == "http" and method in _STATE_CHANGING:
            problem = self._problem(scope, method)
            if problem is not None:
                await refusal(*problem)(scope, receive, send)
                return
        await self.app(scope, receive, send)

    @staticmethod
    def _problem(scope: Scope, method: str) -> tuple[int, str] | None:
        fetch_site = (_header(scope, b"sec-fetch-site") or "").strip().lower()
        if fetch_site in ("cross-site", "same-site"):
            return 403, (f"{method} from another site refused (Sec-Fetch-Site: {fetch_site}): only the workbench's "
                         "own page may change its state")  # fmt: skip
        origin = _header(scope, b"origin")
        host = _header(scope, b"host") or ""
        if origin is not None:
            parts = urlsplit(origin.strip().lower())
            default = {"http": 80, "https": 443}.get(parts.scheme)
            name, port = _split_host(host)
            ours = (name, port if port is not None else {"http": 80, "https": 443}.get(scope.get("scheme", "http")))
            try:
                theirs = (parts.hostname or "", parts.port if parts.port is not None else default)
            except ValueError:  # a port that is not a number
                theirs = ("", None)
            if default is None or theirs != ours or parts.path or parts.query:
                return 403, (f"{method} from Origin {_shown(origin)} refused: only the workbench's own page "
                             f"(http://{host}) may change its state")  # fmt: skip
        if method not in _WITH_BODY:
            return None
        media = (_header(scope, b"content-type") or "").split(";")[0].strip().lower()
        if scope.get("path") == _UPLOADS or media == "application/json":
            return None  # the upload route checks its own list (UploadStore.check_declared), 415 too
        got = _shown(media) if media else "none"
        return 415, f"Content-Type must be application/json on {method} {scope.get('path', '')}; got {got}"


def add_guards(app: object, *, allowed_hosts: Iterable[str] = (), token: str | None = None) -> None:
    """Install the guards on a Starlette/FastAPI ``app``, outside its other middlewares.

    Parameters
    ----------
    app : fastapi.FastAPI
        The application (its ``add_middleware`` puts each new one outermost).
    allowed_hosts : iterable of str
        Host names or addresses served besides the loopback ones (:func:`host_allowed`).
    token : str, optional
        The token every request must carry (:class:`TokenGuard`); None: no token.
    """
    app.add_middleware(OriginGuard)  # type: ignore[attr-defined]
    if token is not None:
        app.add_middleware(TokenGuard, token=token)  # type: ignore[attr-defined]
    app.add_middleware(HostGuard, allowed=tuple(allowed_hosts))  # type: ignore[attr-defined]
