"""The numbers the workbench's overlays draw with (issue 30), besides the maps the jobs write.

A page draws a disparity map of a job as a heat map over the image and as a histogram against the display's
comfort zone and divergence limit (``static/pages/overlays.js``); what the drawing needs that depends on the
display (the zone, the limit, the colour scale's ticks) is converted here by the library and served beside the job:

- ``GET /api/stereo/{job_id}/overlay`` (:func:`stereo_overlay`): a ``synthesize`` job's parallax map (page 2), or
  for a stereo pair its input as matched (the matching result, ``?of=input``), in px of the pair, with the
  stereo-window rule of :mod:`vergence.video` and the pair's vertical disparity;
- ``GET /api/specular/{job_id}/overlay`` (:func:`specular_overlay`): a specular job's per-layer disparity after the
  solve (``disparity_after.npy``, page 5), in arcmin of vergence on the display as the image is shown.
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI, Query
from fastapi.responses import JSONResponse, Response

from vergence.web._errors import refusal
from vergence.web.jobs import JobManager

__all__ = ["HEAT_SCALE_ARCMIN", "MATCHED_PARALLAX_FILE", "MAX_HEAT_SCALE_ARCMIN", "OVERLAY_OF", "PARALLAX_FILE",
           "WINDOW_MASK_PERCENTILE", "add_specular_routes", "add_stereo_routes", "specular_overlay", "stereo_overlay"]

#: The parallax map each job writes (``P = x_r - x_l``, image px of the pair, float32 ``(H, W)``, NaN unknown).
PARALLAX_FILE = "parallax.npy"

#: A stereo pair's own parallax as matched (``-d``, ``d = x_l - x_r``; px of the pair, float32 ``(H, W)``, NaN
#: unknown), written with the views it was matched on.
MATCHED_PARALLAX_FILE = "matched_parallax.npy"

#: What ``GET /api/stereo/{id}/overlay?of=`` draws, and its map and views: the synthesized pair, or a stereo
#: pair's input as matched.
OVERLAY_OF = {"result": (PARALLAX_FILE, ("left.png", "right.png")),
              "input": (MATCHED_PARALLAX_FILE, ("input_left.png", "input_right.png"))}

#: The heat maps' fixed colour scale, +-arcmin of vergence on the job's display (twice the default comfort
#: zone: the zone's limits fall a quarter of the way in from each end); ``?scale_arcmin=`` changes it, up to
#: MAX_HEAT_SCALE_ARCMIN (10 degrees).
HEAT_SCALE_ARCMIN = 120.0
MAX_HEAT_SCALE_ARCMIN = 600.0

#: The floating window's width at a violating edge: this percentile of the crossed parallax in the edge band,
#: rounded up to whole columns (as ``vergence convert --floating-window``: a few stray pixels do not widen it).
WINDOW_MASK_PERCENTILE = 95


def _check_scale(scale_arcmin: float) -> None:
    if not 0 < scale_arcmin <= MAX_HEAT_SCALE_ARCMIN:  # NaN fails too
        raise ValueError(f"scale_arcmin must be > 0 and at most {MAX_HEAT_SCALE_ARCMIN:g}; got {scale_arcmin!r}")


def stereo_overlay(summary: dict[str, Any], *, scale_arcmin: float = HEAT_SCALE_ARCMIN,
                   of: str = "result") -> dict[str, Any]:
    """What the page's overlays need besides the parallax map, for a done ``synthesize`` job's ``summary``:
    every length in px of the pair (``P = x_r - x_l``, positive behind the screen), converted by the library.

    The image fills the display's width: one px of the pair is ``resolution / W`` display px
    (:func:`vergence.synthesis.plan_comfort`'s rule). ``zone_px``: the comfort zone
    (:meth:`vergence.viewing.ComfortZone.pixels`, exact vergence angles); ``divergence_px``: the divergence limit
    ``b'/W'`` of S0 Eq. (8) times ``W``; ``scale``: the heat map's fixed colour scale, ``+-scale_arcmin``
    (:func:`vergence.viewing.pixels_from_arcmin`) with ticks every quarter; ``window``: the stereo-window rule
    of ``vergence analyze`` (:data:`vergence.video.WINDOW_BAND`, ``WINDOW_MIN_PX``, ``WINDOW_SHARE``) and the
    floating window's percentile (:data:`WINDOW_MASK_PERCENTILE`); ``parallax`` and ``views``: the files drawn,
    those of ``of`` in :data:`OVERLAY_OF` (the synthesized pair, or a stereo pair's input as matched).
    """
    _check_scale(scale_arcmin)
    if of not in OVERLAY_OF:
        raise ValueError(f"of must be one of {', '.join(OVERLAY_OF)}; got {of!r}")
    if of == "input" and summary["source"] != "pair":
        raise ValueError(f"of=input needs a job of a stereo pair (its input as matched); this job's input is "
                         f"{summary['source']!r}")  # fmt: skip
    parallax, views = OVERLAY_OF[of]
    import numpy as np

    from vergence.video import WINDOW_BAND, WINDOW_MIN_PX, WINDOW_SHARE
    from vergence.viewing import ComfortZone, Display, pixels_from_arcmin

    display = Display.preset(summary["display"]["preset"])  # a done job's, checked when it was asked for
    width, height = summary["size"]
    per_px = display.resolution / width  # display px per px of the pair
    zone = ComfortZone()
    ticks = np.linspace(-scale_arcmin, scale_arcmin, 9)
    ticks_px = np.asarray(pixels_from_arcmin(ticks, display)) / per_px
    lo, hi = zone.pixels(display)
    return {
        "width": width, "height": height, "display": summary["display"]["preset"], "display_px_per_px": per_px,
        "zone_arcmin": [zone.min_arcmin, zone.max_arcmin], "zone_px": [lo / per_px, hi / per_px],
        "divergence_px": display.divergence_disparity * width,
        "scale": {"arcmin": [-scale_arcmin, scale_arcmin], "px": [float(ticks_px[0]), float(ticks_px[-1])],
                  "ticks": [{"arcmin": float(a), "px": float(p)} for a, p in zip(ticks, ticks_px)]},
        "window": {"band_px": min(width, max(2, int(round(WINDOW_BAND * width)))), "min_px": WINDOW_MIN_PX,
                   "share": WINDOW_SHARE, "mask_percentile": WINDOW_MASK_PERCENTILE},
        "of": of, "parallax": parallax, "views": list(views), "row_alignment": summary.get("row_alignment"),
    }  # fmt: skip


def _done_result(jobs: JobManager, job_id: str, kinds: tuple[str, ...], named: str) -> dict[str, Any] | Response:
    """The result of the done job ``job_id`` of one of ``kinds``, or the refusal to answer: 404 for an unknown id
    or a job of another kind (``named`` in the message), 409 before it is done."""
    try:
        status, _ = jobs.status(jobs.get(job_id))
    except KeyError as exc:
        return refusal(404, str(exc.args[0]))
    if status["kind"] not in kinds:
        return refusal(404, f"job {job_id} is a {status['kind']} job, not a {named} job")
    if status["state"] != "done":
        return refusal(409, f"job {job_id} is {status['state']}: its overlays exist once it is done")
    return status["result"]


def add_stereo_routes(app: FastAPI, jobs: JobManager) -> None:
    """``GET /api/stereo/{job_id}/overlay``: :func:`stereo_overlay` of a done synthesize job."""
    error = {"content": {"application/json": {"example": {"error": "one line"}}}}

    @app.get("/api/stereo/{job_id}/overlay", summary="What the 2D + depth page's overlays need for a synthesize job",
             responses={404: error, 409: error, 422: error})
    def overlay(job_id: str, scale_arcmin: float = Query(
            HEAT_SCALE_ARCMIN, gt=0, le=MAX_HEAT_SCALE_ARCMIN, allow_inf_nan=False,
            description="The heat map's colour scale, +-arcmin of vergence on the job's display."),
            of: str = Query("result", description="What to draw: 'result' (the synthesized pair) or 'input' "
                            "(a stereo pair as matched).")) -> Response:
        """The comfort zone, divergence limit and colour scale in px of the pair, the stereo-window rule, the
        name of the job's parallax map (``GET /api/jobs/{job_id}/files/parallax.npy``) and, for a stereo pair,
        its vertical disparity; 404 for an unknown id or another kind of job, 409 before it is done."""
        result = _done_result(jobs, job_id, ("synthesize",), "synthesize")
        if isinstance(result, Response):
            return result
        try:
            return JSONResponse(stereo_overlay(result, scale_arcmin=scale_arcmin, of=of))
        except ValueError as exc:
            return refusal(422, str(exc))


def specular_overlay(report: dict[str, Any], *, scale_arcmin: float = HEAT_SCALE_ARCMIN) -> dict[str, Any]:
    """What the page's overlays of ``disparity_after.npy`` (``(N, H, W)`` arcmin, positive behind the screen)
    need besides the array, for a done specular job's ``report``, every figure in arcmin of vergence on the
    display as the image is shown (``report["display"]``, :func:`vergence.specular.display_block`).

    ``zone_arcmin``: ``report["comfort_zone_arcmin"]``; ``divergence_arcmin``: the vergence change of a screen
    parallax of one eye separation (the eyes parallel, S0 Eq. (8)'s limit ``b'``), i.e. ``2 atan(e / 2D)``
    (:func:`vergence.viewing.arcmin_from_pixels`, exact); ``scale``: the heat map's range ``+-scale_arcmin`` and
    its ticks every quarter; ``layers``: the layers' names (:func:`vergence.specular.layer_labels`).
    """
    _check_scale(scale_arcmin)
    import numpy as np

    from vergence.viewing import Display, arcmin_from_pixels

    block = report["display"]
    shown = Display(eye_separation=block["eye_separation_m"], distance=block["viewing_distance_m"],
                    width=block["shown_width_m"], resolution=block["image_width_px"])  # fmt: skip
    divergence = float(arcmin_from_pixels(shown.eye_separation / shown.pixel_pitch, shown, exact=True))
    ticks = np.linspace(-scale_arcmin, scale_arcmin, 9)
    return {
        "display": block["name"], "fit": block["fit"], "arcmin_per_px": block["arcmin_per_px"],
        "zone_arcmin": list(report["comfort_zone_arcmin"]), "divergence_arcmin": divergence,
        "scale": {"arcmin": [-scale_arcmin, scale_arcmin], "ticks": [float(t) for t in ticks]},
        "layers": [{"layer": layer["layer"], "name": layer["name"]} for layer in report["layers"]],
        "disparity": "disparity_after.npy",
    }  # fmt: skip


def add_specular_routes(app: FastAPI, jobs: JobManager) -> None:
    """``GET /api/specular/{job_id}/overlay``: :func:`specular_overlay` of a done specular job or re-optimisation."""
    error = {"content": {"application/json": {"example": {"error": "one line"}}}}

    @app.get("/api/specular/{job_id}/overlay", summary="What the specular page's overlays need for a specular job",
             responses={404: error, 409: error, 422: error})
    def overlay(job_id: str, scale_arcmin: float = Query(
            HEAT_SCALE_ARCMIN, gt=0, le=MAX_HEAT_SCALE_ARCMIN, allow_inf_nan=False,
            description="The heat map's colour scale, +-arcmin of vergence on the job's display.")) -> Response:
        """The comfort zone, the divergence limit and the colour scale in arcmin of the job's display (as shown),
        and the name of its disparity array (``GET /api/jobs/{job_id}/files/disparity_after.npy``); 404 for an
        unknown id or a job of another kind, 409 before it is done."""
        result = _done_result(jobs, job_id, ("specular", "specular-reoptimise"), "specular")
        if isinstance(result, Response):
            return result
        return JSONResponse(specular_overlay(result, scale_arcmin=scale_arcmin))
