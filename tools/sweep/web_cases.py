"""Web cases: hostile requests for every route of the workbench (``vergence serve``, issue 29).

The routes are read from the app (``app.routes``); a body's fields from the models the app validates
with: a twin's (``app.state.twins``), a job kind's (``app.state.jobs.kinds``), StereoSpace's move and
pair requests; the rig planner's shot from its example (the kinds of its values). Each route gets:

- a foreign ``Host`` (every method; refused 400, DNS rebinding);
- on POST and DELETE, a foreign ``Origin`` (another site, another port, ``null``) and
  ``Sec-Fetch-Site: cross-site`` (403);
- on POST, a body not sent as JSON (``text/plain``, form-encoded, multipart, none: 415), a body over
  :data:`vergence.web.MAX_JSON_BODY` declared or chunked (413), invalid JSON, JSON that is no object,
  nesting 100,000 deep, bytes that are no UTF-8, an empty body, a wrong method;
- path parameters that are paths (``../``, ``/etc/passwd``, ``%2F..``), NUL and control characters,
  5,000 characters, the absolute path of a data file, the id a file outside the data folder would have;
- one hostile value per body field at a time, from its kind (:data:`VALUES`): text for numbers, ``"nan"``
  and ``NaN``, ``"inf"``, negative and zero quantities, empty strings, lists past
  :data:`vergence.commands.MAX_LIST_ITEMS`, ids that are paths;
- uploads: a PNG header alone, truncated PNG, JPEG and PFM files, a PFM whose header lies about its
  size, headers declaring 10^10 pixels, names with NUL and control characters.

A case is plain data (:class:`WebCase`); the ids it needs (uploads, data entries, a done job) come from
a :class:`WebContext` the runner (:mod:`tools.sweep.web_runner`) fills once the server is up.
"""

from __future__ import annotations

import copy
import json
import random
import re
import types
import typing
from dataclasses import dataclass, field
from urllib.parse import quote

__all__ = ["FOREIGN_HOST", "FOREIGN_ORIGIN", "JOB_BASES", "QUICK_PER_FIELD", "TWIN_BASES", "VALUES", "WebCase",
           "WebContext", "body_routes", "route_table", "web_cases"]

FOREIGN_HOST = "rebind.attacker.example"
FOREIGN_ORIGIN = "http://evil.example"
# Hostile values drawn per body field in a quick sweep (all of them otherwise).
QUICK_PER_FIELD = 2
FAKE_ID = "0123456789abcdef"  # an id of the right shape that stands for nothing
NESTING = 100_000  # JSON nesting past Python's recursion limit

# Valid bodies of the twins ("{name}": an id of WebContext.ids: an upload of the sweep's fixtures by its
# stem, or a data entry). Tiny inputs: each answers in well under a second once the kernels are cached.
TWIN_BASES: dict[str, dict] = {
    "analyze": {"input_path": "{image}", "depth": "{depth}", "depth_kind": "metric", "display": "tv-55"},
    "budget": {"baseline": 0.1, "convergence": 3, "window": 1, "display": "tv-55", "depth": [5]},
    "compare": {"image": "{image}", "reference": "{image_noisy}"},
    "evaluate-disparity": {"estimate": "{disp_left}", "truth": "{disp_left_noisy}"},
    "interpolate": {"left": "{image}", "left_disparity": "{disp_left}", "right": "{image_right}",
                    "right_disparity": "{disp_right}", "position": 0.5},
    "mapping": {"reference_baseline": 0.5, "convergence": 20, "window": 2.5, "display": "tv-55",
                "constraint": ["z=20,perceived=2.2,roundness=1"], "near": 10, "far": 100},
    "match": {"left": "{image}", "right": "{image_right}", "max_disparity": 16},
    "rectify": {"left": "{left}", "right": "{right}", "cameras": "{cameras}"},
    "rig/plan": {"shot": "{shot}"},
    "synthesize": {"image": "{image}", "depth": "{depth}", "budget_px": 4},
}
# A shot small enough to render in a second as a rig job (the planner's example, 16 px wide).
_SHOT = {"rig": "tri", "scene": "stadium", "display": "tv-55",
         "camera": {"position": [0.0, 2.2, 0.0], "look_at": [0.0, 1.1, -30.0], "fov_deg": 8.0, "width": 480,
                    "height": 270}, "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=6"]}
# Job bodies: tiny sizes (a 1-pixel render, a 4 x 3 specular table) so that a job that starts ends in
# seconds; the re-optimisation names no done specular job (404); the StereoSpace job opens the
# collection whose images lead outside (it fails in one line, reading none of them).
JOB_BASES: dict[str, dict] = {
    "render": {"scene": "scene:tabletop", "width": 1, "height": 1, "depth": 0, "samples": 1},
    "specular": {"scene": "scene:glasses", "width": 4, "height": 3, "k": 2, "depth": 0, "samples": 1},
    "specular-reoptimise": {"job": FAKE_ID, "weights": [1, 1, 10, 0.1]},
    "synthesize": {"example": "scene:tabletop", "example_width": 8, "example_height": 6, "budget_px": 2},
    "rig": {"shot": _SHOT, "width": 32, "samples": 1},
    "stereospace": {"collection": "{collection_out}", "grid_step": 16},
}
_STATE = {"region": [0, 0], "li": 0.0, "lj": 1.0}
OTHER_BASES: dict[str, dict] = {
    "/api/stereospace/{job_id}/move": {"state": _STATE, "pan": 0.1, "zoom": 0.0},
    "/api/stereospace/{job_id}/pair": {"state": _STATE, "format": "anaglyph", "width": 64},
    "/api/rigs/plan": _SHOT,
    "/api/{command}": {},
}


def _over(item: str, count: int) -> str:
    return "[" + ",".join([item] * count) + "]"


# Hostile JSON values by field kind: (name, JSON text, strict). Strict: clearly invalid, so a 2xx accepts it.
VALUES: dict[str, tuple[tuple[str, str, bool], ...]] = {
    "number": (("text", '"abc"', True), ("nan_text", '"nan"', True), ("nan_literal", "NaN", True),
               ("inf_text", '"inf"', False), ("neg_inf_text", '"-inf"', False), ("negative", "-1", False),
               ("zero", "0", False), ("huge", "1e308", False), ("overflow", "1e999", False), ("empty", '""', True),
               ("bool", "true", True), ("null", "null", False), ("list", "[1]", True), ("digits", "9" * 5000, False)),
    "integer": (("fraction", "1.5", True), ("text", '"abc"', True), ("nan_text", '"nan"', True),
                ("negative", "-1", False), ("zero", "0", False), ("int64_overflow", str(2**63), False),
                ("huge", str(10**30), False), ("digits", "9" * 5000, False), ("bool", "true", True),
                ("empty", '""', True), ("null", "null", False), ("list", "[1]", True)),
    "text": (("empty", '""', False), ("long", json.dumps("x" * 5000), False), ("number", "1", True),
             ("nul", json.dumps("a\x00b"), False), ("control", json.dumps("a\nb\x1b[31m"), False),
             ("dotdot", json.dumps("../../etc/passwd"), False), ("absolute", '"/etc/passwd"', False),
             ("null", "null", False), ("list", '["x"]', True)),
    # an id (of an upload, a data entry, a job): never a path
    "id": (("dotdot", json.dumps("../../etc/passwd"), True), ("absolute", '"/etc/passwd"', True),
           ("encoded", '"..%2F..%2Fetc%2Fpasswd"', True), ("nul", json.dumps("\x00"), True), ("empty", '""', True),
           ("long", json.dumps("x" * 5000), True), ("number", "1", True), ("data_path", "{data_path}", True),
           ("outside_id", "{outside_id}", True), ("other_entry", "{cameras}", False)),
    "flag": (("text", '"maybe"', True), ("number", "2", True), ("nan_text", '"nan"', True), ("null", "null", True),
             ("list", "[true]", True)),
    "list": (("empty", "[]", False), ("scalar", "{item}", True), ("nested", "[[1]]", True), ("text", '"abc"', True),
             ("null_items", "[null]", True), ("over_max", "{over_max}", True), ("null", "null", False)),
    "object": (("list", "[]", True), ("text", '"x"', True), ("empty", "{}", False), ("null", "null", False),
               ("deep", "[" * 2000 + "]" * 2000, True)),
}


@dataclass(frozen=True)
class WebCase:
    """One request: what is sent, and what a well-guarded server answers."""

    id: str
    target: str  # the route, "POST /api/budget"
    method: str
    url: str  # path and query as sent (percent-encoded)
    headers: tuple[tuple[str, str], ...] = (("Content-Type", "application/json"),)
    body: bytes | None = None
    hostile: bool = True
    strict: bool = False  # clearly invalid: a 2xx accepts it
    expect: tuple[int, ...] = ()  # a guard's refusal: any other answer below 500 reached the route
    chunked: bool = False
    declared_length: int | None = None  # a Content-Length other than the body's
    follow: bool = False  # a job started by this valid request is followed to its end (not cancelled)


@dataclass
class WebContext:
    """Ids and facts of the running server that cases need.

    ``ids``: an upload of each fixture by its stem (``image``, ``disp_left``, ...) and data entries by
    role (``cameras``, ``shot``, ``collection_out``, ``truncated``); ``job``: a done render job and
    ``job_file`` one of its files; ``data_path``: the absolute path of a data file; ``outside_id``: the
    id that a file outside the data folder would have; ``port``: the server's.
    """

    ids: dict[str, str]
    job: str = FAKE_ID
    job_file: str = "beauty.png"
    data_path: str = "/nonexistent"
    outside_id: str = "collection-0000000000000000"
    port: int = 0
    fixtures: dict[str, bytes] = field(default_factory=dict)  # upload bodies: name -> bytes

    def fill(self, value):  # noqa: ANN001, ANN201 - JSON data in, JSON data out
        """``value`` with each ``"{name}"`` string replaced by its id."""
        if isinstance(value, str) and value.startswith("{") and value.endswith("}") and value[1:-1] in self.ids:
            return self.ids[value[1:-1]]
        if isinstance(value, dict):
            return {k: self.fill(v) for k, v in value.items()}
        if isinstance(value, list):
            return [self.fill(v) for v in value]
        return value


# ------------------------------------------------------------------------------------- routes
def route_table(app) -> list[tuple[str, str]]:  # noqa: ANN001 - a FastAPI app
    """Every (method, path template) the app serves (HEAD left out; a mount as ``/static/{path}``)."""
    from starlette.routing import Mount

    table = []
    for route in app.routes:
        if isinstance(route, Mount):
            table.append(("GET", route.path + "/{path}"))
            continue
        for method in sorted(getattr(route, "methods", None) or ()):
            if method != "HEAD":
                table.append((method, route.path))
    return table


def body_routes(app) -> dict[str, tuple[dict, object]]:  # noqa: ANN001
    """Concrete POST path -> (valid body with ``"{name}"`` placeholders, the model it is validated with or None)."""
    from vergence.web.stereospace_page import MoveRequest, PairRequest

    table: dict[str, tuple[dict, object]] = {}
    for path, twin in app.state.twins.items():
        table[f"/api/{path}"] = (TWIN_BASES.get(path, {}), twin.model)
    for name, kind in app.state.jobs.kinds.items():
        table[f"/api/jobs/{name}"] = (JOB_BASES.get(name, {}), kind.model)
    models = {"/api/stereospace/{job_id}/move": MoveRequest, "/api/stereospace/{job_id}/pair": PairRequest}
    for path, base in OTHER_BASES.items():
        table[path] = (base, models.get(path))
    return table


def _unwrap(annotation):  # noqa: ANN001, ANN202
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _unwrap(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return _unwrap(args[0]) if len(args) == 1 else annotation
    return annotation


def _kind_of(annotation, description: str = "") -> tuple[str, object]:  # noqa: ANN001
    """A field's kind (a key of :data:`VALUES`, or ``model``) and its item or model type."""
    import pydantic

    annotation = _unwrap(annotation)
    origin = typing.get_origin(annotation)
    if annotation is bool:
        return "flag", None
    if annotation is int:
        return "integer", None
    if annotation is float:
        return "number", None
    if annotation is str:
        return ("id" if re.search(r"\bids?\b", description) else "text"), None
    if origin in (list, tuple):
        args = [a for a in typing.get_args(annotation) if a is not Ellipsis]
        return "list", (_unwrap(args[0]) if args else None)
    if isinstance(annotation, type) and issubclass(annotation, pydantic.BaseModel):
        return "model", annotation
    return "object", None


def _value_kind(value) -> tuple[str, object]:  # noqa: ANN001 - a JSON value of an example body
    if isinstance(value, bool):
        return "flag", None
    if isinstance(value, int):
        return "integer", None
    if isinstance(value, float):
        return "number", None
    if isinstance(value, str):
        return "text", None
    if isinstance(value, list):
        return "list", (type(value[0]) if value else None)
    return "object", None


def _leaves(base: dict, model) -> list[tuple[tuple[str, ...], str, object, object]]:  # noqa: ANN001
    """(path, kind, item type, base value) of every field: the model's (nested models and objects
    recursed into), else the base's own keys."""
    out = []
    names = list(model.model_fields) if model is not None else list(base)
    for name in names:
        value = base.get(name) if isinstance(base, dict) else None
        if model is not None:
            info = model.model_fields[name]
            kind, extra = _kind_of(info.annotation, info.description or "")
        else:
            kind, extra = _value_kind(value)
        if kind == "model":
            out.append(((name,), "object", None, value))
            out += [((name, *p), k, x, v) for p, k, x, v in _leaves(value if isinstance(value, dict) else {}, extra)]
        elif kind == "object" and isinstance(value, dict):
            out.append(((name,), "object", None, value))
            out += [((name, *p), k, x, v) for p, k, x, v in _leaves(value, None)]
        else:
            out.append(((name,), kind, extra, value))
    return out


_SLOT = "\x00slot\x00"


def _with(base: dict, path: tuple[str, ...], text: str | None) -> bytes:
    """``base`` as JSON with the field at ``path`` replaced by the JSON ``text`` (None: left out)."""
    body = copy.deepcopy(base)
    node = body
    for key in path[:-1]:
        if not isinstance(node.get(key), dict):
            node[key] = {}
        node = node[key]
    if text is None:
        node.pop(path[-1], None)
        return json.dumps(body).encode()
    node[path[-1]] = _SLOT
    return json.dumps(body).replace(json.dumps(_SLOT), text).encode()


def _item_text(item_type, value) -> str:  # noqa: ANN001
    if isinstance(value, list) and value:
        return json.dumps(value[0])
    return {str: '"x"', int: "1", float: "1.0", bool: "true"}.get(item_type, "{}" if item_type else "1")


def _field_values(kind: str, item_type, value, ctx: WebContext) -> list[tuple[str, str, bool]]:  # noqa: ANN001
    from vergence.commands import MAX_LIST_ITEMS

    item = _item_text(item_type, value)
    filled = {"{item}": item, "{over_max}": _over(item, MAX_LIST_ITEMS + 1), "{data_path}": json.dumps(ctx.data_path),
              "{outside_id}": json.dumps(ctx.outside_id), "{cameras}": json.dumps(ctx.ids.get("cameras", FAKE_ID))}
    return [(name, filled.get(text, text), strict) for name, text, strict in VALUES[kind]]


# --------------------------------------------------------------------------------------- cases
_HOSTILE_IDS = (("dotdot", "..%2F..%2Fetc%2Fpasswd"), ("absolute", "%2Fetc%2Fpasswd"), ("nul", "%00"),
                ("control", "a%0Ab%1B%5B31m"), ("long", "x" * 5000), ("dot", "."), ("rtl", "%E2%80%AEgnp.exe"),
                ("data_path", "{data_path}"), ("outside_id", "{outside_id}"), ("raw_dotdot", "../../../etc/passwd"))
# Valid path values by parameter ("{...}": from the context).
_PARAMS = {"entry_id": "{cameras}", "job_id": "{job}", "name": "{job_file}", "upload_id": "{image}", "kind": "render",
           "command": "no-such-command", "path": "common.js"}
_UPLOAD_TYPES = {"png": "image/png", "jpg": "image/jpeg", "pfm": "image/x-portable-floatmap",
                 "npy": "application/octet-stream"}


def _path(template: str, ctx: WebContext, override: dict[str, str] | None = None) -> str:
    def value(match: re.Match) -> str:
        name = match.group(1)
        if override and name in override:
            return override[name]
        raw = _PARAMS.get(name, FAKE_ID)
        if "stereospace" in template and name == "job_id":
            return FAKE_ID  # no StereoSpace job is prepared: its follow-ups answer 404 after validation
        if "stereospace" in template and name == "name":
            return "left.png"
        if raw == "{job}":
            return ctx.job
        if raw == "{job_file}":
            return quote(ctx.job_file, safe="")
        if raw.startswith("{"):
            return quote(ctx.ids.get(raw[1:-1], FAKE_ID), safe="")
        return raw

    return re.sub(r"\{(\w+)(?::\w+)?\}", value, template)


def _guard_cases(method: str, template: str, url: str, body: bytes | None, port: int,
                 validated: bool) -> list[WebCase]:
    """The guards' cases of a route, and on a POST route the body's (``validated``: the route reads a
    JSON body, so a body that is no JSON object is refused 422)."""
    target = f"{method} {template}"
    media = _UPLOAD_TYPES["png"] if template == "/api/uploads" else "application/json"
    json_type = (("Content-Type", media),) if method == "POST" else ()
    cases = [WebCase(f"web/{target}/Host=foreign", target, method, url, (("Host", FOREIGN_HOST), *json_type), body,
                     strict=True, expect=(400,))]
    if method == "GET":
        return cases
    origins = (("foreign", FOREIGN_ORIGIN), ("other_port", f"http://127.0.0.1:{port + 1}"), ("null", "null"))
    cases += [WebCase(f"web/{target}/Origin={name}", target, method, url, (("Origin", origin), *json_type), body,
                      strict=True, expect=(403,)) for name, origin in origins]
    cases.append(WebCase(f"web/{target}/Sec-Fetch-Site=cross-site", target, method, url,
                         (("Sec-Fetch-Site", "cross-site"), *json_type), body, strict=True, expect=(403,)))
    if method != "POST":
        return cases
    for name, media in (("text_plain", "text/plain"), ("form", "application/x-www-form-urlencoded"),
                        ("multipart", "multipart/form-data; boundary=x"), ("json_lookalike", "application/jsonx")):
        cases.append(WebCase(f"web/{target}/Content-Type={name}", target, method, url, (("Content-Type", media),),
                             body, strict=True, expect=(415,)))
    cases.append(WebCase(f"web/{target}/Content-Type=none", target, method, url, (), body, strict=True, expect=(415,)))
    if template == "/api/uploads":
        return cases
    from vergence.web import MAX_JSON_BODY

    over = b" " * (MAX_JSON_BODY + 1)
    cases += [
        WebCase(f"web/{target}/body=over_limit", target, method, url, body=over, strict=True, expect=(413,)),
        WebCase(f"web/{target}/body=over_limit_chunked", target, method, url, body=over, strict=True, expect=(413,),
                chunked=True),
        WebCase(f"web/{target}/body=empty", target, method, url, body=b""),
        WebCase(f"web/{target}/method=PUT", target, "PUT", url, body=body or b"{}", strict=True, expect=(405,)),
    ]
    refused = (400, 422) if validated else ()  # 400: FastAPI's own "error parsing the body"
    bad = {"invalid_json": b'{"a": ', "array": b"[]", "string": b'"x"', "null": b"null",
           "nested": b"[" * NESTING + b"]" * NESTING, "not_utf8": b'{"x": "\xff\xfe"}'}
    return cases + [WebCase(f"web/{target}/body={name}", target, method, url, body=data, strict=True, expect=refused)
                    for name, data in bad.items()]


def _upload_cases(ctx: WebContext) -> list[WebCase]:
    from tools.sweep.hostile import HUGE_SIDE, hostile_files, png_bytes

    target = "POST /api/uploads"
    png = ctx.fixtures.get("image.png", png_bytes(2, 2))
    files = hostile_files()
    bodies = {"png_header_only": (png[:33], "png"), "truncated_png": (files["truncated_png"], "png"),
              "truncated_jpeg": (files["truncated_jpeg"], "jpg"), "truncated_pfm": (files["truncated_pfm"], "pfm"),
              "pfm_lying_header": (b"Pf\n1000 1000\n-1.0\n" + b"\0" * 64, "pfm"),
              "pfm_huge_header": (f"Pf\n{HUGE_SIDE} {HUGE_SIDE}\n-1.0\n".encode() + b"\0" * 64, "pfm"),
              "huge_png": (files["huge_png"], "png"), "huge_jpeg": (files["huge_jpeg"], "jpg"),
              "npy_garbage": (b"\x93NUMPY\x01\x00" + b"\xff" * 40, "npy"), "garbage": (files["garbage"], "png"),
              "empty": (b"", "png"), "png_as_pfm": (png, "pfm")}
    # a PNG sent as PFM is stored as PNG (the content decides): valid
    cases = [WebCase(f"web/{target}/file={name}", target, "POST", "/api/uploads?name=x",
                     (("Content-Type", _UPLOAD_TYPES[kind]),), data, strict=name != "png_as_pfm")
             for name, (data, kind) in bodies.items()]
    names = {"nul": ("a%00b.png", True), "newline": ("a%0Ab.png", True), "escape": ("%1B%5B31m.png", True),
             "del": ("a%7F.png", True), "dotdot": ("..%2F..%2Fetc%2Fpasswd", False), "long": ("x" * 5000, False),
             "rtl": ("%E2%80%AEgnp.exe", False), "not_utf8": ("%FF%FE.png", False)}
    cases += [WebCase(f"web/{target}/name={name}", target, "POST", f"/api/uploads?name={text}",
                      (("Content-Type", "image/png"),), png, strict=strict) for name, (text, strict) in names.items()]
    cases.append(WebCase(f"web/{target}/declared_over_limit", target, "POST", "/api/uploads",
                         (("Content-Type", "image/png"),), b"", strict=True, expect=(413,), declared_length=2**40))
    return cases


def _concrete_paths(method: str, template: str, bodies: dict) -> list[str]:
    """Where a route's requests go: a POST route with a path parameter and no body of its own
    (``/api/jobs/{kind}``) once per body it takes (a job kind each), any other route at its template."""
    if method != "POST" or template in bodies or "{" not in template:
        return [template]
    pattern = re.sub(r"\{\w+\}", "[^/]+", template)
    return [path for path in bodies if re.fullmatch(pattern, path)] or [template]


def _field_cases(label: str, url: str, filled: dict, model, ctx: WebContext, rng: random.Random | None,  # noqa: ANN001
                 per_field: int) -> list[WebCase]:
    """One hostile value per body field at a time (``rng``: a quick sweep draws ``per_field`` of them)."""
    # a clearly invalid value is refused by validation (400, 422); an id may also be unknown (404), and so
    # may the base's own id where the route looks it up first
    lookup_first = FAKE_ID in json.dumps(filled)
    cases = []
    for leaf, kind, item_type, value in _leaves(filled, model):
        values = _field_values(kind, item_type, value, ctx)
        if rng is not None:
            values = rng.sample(values, min(per_field, len(values)))
        refused = (400, 404, 422) if kind == "id" or lookup_first else (400, 422)
        cases += [WebCase(f"web/{label}/{'.'.join(leaf)}={name}", label, "POST", url, body=_with(filled, leaf, text),
                          strict=strict, expect=refused if strict else ()) for name, text, strict in values]
    return cases


def _id_cases(method: str, template: str, ctx: WebContext) -> list[WebCase]:
    """Each path parameter replaced by a hostile id (a path, NUL, control characters, 5,000 characters)."""
    cases = []
    for param in re.findall(r"\{(\w+)(?::\w+)?\}", template):
        for name, raw in _HOSTILE_IDS:
            text = {"{data_path}": quote(ctx.data_path, safe=""), "{outside_id}": ctx.outside_id}.get(raw, raw)
            cases.append(WebCase(f"web/{method} {template}/{param}={name}", f"{method} {template}", method,
                                 _path(template, ctx, {param: text}), body=b"{}" if method == "POST" else None,
                                 strict=True))
    return cases


# Hostile query values (percent-encoded) for every query parameter of a GET route (issue 30's overlay
# routes: ``?scale_arcmin=``, ``?of=``): validation answers 422, or the route's own 4xx.
_HOSTILE_QUERY = (("nan", "nan"), ("inf", "inf"), ("negative", "-1"), ("zero", "0"), ("huge", "1e308"),
                  ("empty", ""), ("nul", "%00"), ("control", "a%0Ab%1B%5B31m"), ("text", "abc"), ("long", "x" * 5000),
                  ("dotdot", "..%2F..%2Fetc%2Fpasswd"))


def _query_cases(app, ctx: WebContext) -> list[WebCase]:  # noqa: ANN001 - a FastAPI app
    """Each query parameter of each GET route replaced by a hostile value, one at a time."""
    cases = []
    for route in app.routes:
        params = getattr(getattr(route, "dependant", None), "query_params", ())
        if "GET" not in (getattr(route, "methods", None) or ()) or not params:
            continue
        target = f"GET {route.path}"
        for param in params:
            for name, text in _HOSTILE_QUERY:
                cases.append(WebCase(f"web/{target}?{param.name}={name}", target, "GET",
                                     f"{_path(route.path, ctx)}?{param.name}={text}", strict=True,
                                     expect=(400, 404, 409, 422)))
    return cases


def web_cases(app, ctx: WebContext, *, quick: bool, rng: random.Random,  # noqa: ANN001
              per_field: int = QUICK_PER_FIELD) -> list[WebCase]:
    """Every route's cases (module notes): the valid bases first, then guards, bodies, fields and path ids."""
    bodies = body_routes(app)
    png = ctx.fixtures.get("image.png", b"")
    bases: list[WebCase] = []
    cases: list[WebCase] = []
    for method, template in route_table(app):
        target = f"{method} {template}"
        if template == "/api/uploads":
            bases.append(WebCase(f"web/{target}/base", target, method, "/api/uploads?name=image.png",
                                 (("Content-Type", "image/png"),), png, hostile=False))
            cases += _guard_cases(method, template, template, png, ctx.port, validated=False) + _upload_cases(ctx)
            continue
        for i, path in enumerate(_concrete_paths(method, template, bodies)):
            base, model = bodies.get(path, ({}, None))
            filled, url = ctx.fill(base), _path(path, ctx)
            body = json.dumps(filled).encode() if method == "POST" else None
            label = target if path == template else f"{method} {path}"
            bases.append(WebCase(f"web/{label}/base", label, method, url, body=body, hostile=False,
                                 follow=method == "POST" and path.startswith("/api/jobs/")))
            if i == 0:
                cases += _guard_cases(method, template, url, body, ctx.port, validated=bool(base or model))
            if method == "POST":
                cases += _field_cases(label, url, filled, model, ctx, rng if quick else None, per_field)
        cases += _id_cases(method, template, ctx)
    return bases + cases + _query_cases(app, ctx)
