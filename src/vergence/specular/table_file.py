"""The offset table of a run, kept on disk and solved again later (S3 §3.4: "re-optimise" without re-rendering).

S3 §3.4 tabulates ``g(y)`` once (k + 1 renders of the left eye, their matches and their analysis)
so that a new weight or a painted map only re-runs the per-pixel descent and one render.
:class:`SpecularTable` is what that needs: the analysis (:class:`~vergence.specular.OffsetAnalysis`),
the physical pair (whose cameras are the rig), the comfort zone, the exposure, the match cutoff and
window, and the run's settings (with its ``display`` block: the screen and the fit). It comes from
:meth:`SpecularResult.table() <vergence.specular.SpecularResult.table>` (a run with ``keep_table``);
:func:`write_specular_table` stores it in one compressed ``.npz`` (atomically),
:func:`read_specular_table` reads it back with every part checked, and :func:`specular_from_table`
re-solves it for new weights or maps, renders the final left eye and measures it, as
:func:`~vergence.specular.specular_stereo` would with the same options.
"""

from __future__ import annotations

import json
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vergence.specular.tabulated import OffsetAnalysis
from vergence.viewing.comfort import ComfortZone

__all__ = ["TABLE_FILE", "TABLE_FORMAT", "SpecularTable", "read_specular_table", "write_specular_table"]

#: The table's file name in an output folder (``vergence specular --table``).
TABLE_FILE = "specular_table.npz"
#: The ``format`` entry of a table file; its ``version`` is :data:`_VERSION`.
TABLE_FORMAT = "vergence-specular-table"
_VERSION = 1
_RENDER_ARRAYS = ("radiance", "position", "normal", "depth")
_ANALYSIS_ARRAYS = ("offsets", "disparity", "rivalry", "importance")


@dataclass(frozen=True, slots=True, eq=False)
class SpecularTable:
    """An offset table with what re-solving it needs (see the module text).

    Attributes
    ----------
    analysis : OffsetAnalysis
        ``g(y_m)`` of every offset, on the fitted display.
    physical_left, right : vergence.render.RenderResult
        The physical pair; their cameras are the rig.
    zone : ComfortZone
    exposure : float
        The tone map's multiplier shared by every offset and both eyes.
    epsilon : float
        The match cutoff of every state, metres.
    window : tuple of int
        The match window ``(width, height)``.
    settings : dict
        The run's settings (``k``, ``max_depth``, ``samples``, ``factor``, ``variant``, ``alpha``,
        ``near_surface_arcmin``, ``scene``, ``display``, ``objects``, ...), JSON-ready.
    source : dict
        Free JSON-ready notes of the caller (the command line records the scene's file and digest).
    """

    analysis: OffsetAnalysis
    physical_left: object
    right: object
    zone: ComfortZone
    exposure: float
    epsilon: float
    window: tuple
    settings: dict
    source: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.analysis, OffsetAnalysis):
            raise TypeError(f"analysis must be an OffsetAnalysis; got {type(self.analysis).__name__}")
        k1, n, h, w = self.analysis.importance.shape
        for name in ("physical_left", "right"):
            shape = getattr(getattr(self, name), "radiance", np.zeros(0)).shape
            if shape != (n, h, w, 3):
                raise ValueError(f"{name} must be a render of {n} layers of {w}x{h} pixels, as the analysis; "
                                 f"got radiance of shape {shape}")  # fmt: skip


def _render_arrays(prefix: str, result: object) -> dict[str, np.ndarray]:
    cam = result.camera
    out = {f"{prefix}_{name}": np.asarray(getattr(result, name)) for name in _RENDER_ARRAYS}
    if getattr(result, "object_id", None) is not None:
        out[f"{prefix}_object_id"] = np.asarray(result.object_id)
    out |= {f"{prefix}_K": cam.K, f"{prefix}_R": cam.R, f"{prefix}_t": cam.t,
            f"{prefix}_size": np.array([cam.width, cam.height]),
            f"{prefix}_settings": np.array(json.dumps(result.settings.to_dict()))}  # fmt: skip
    return out


def write_specular_table(table: SpecularTable, path: str | Path) -> Path:
    """Store ``table`` in one compressed ``.npz`` at ``path``, atomically (all or nothing).

    The arrays are stored as they are (float32; the analysis alone is ``(k + 1) N H W x 16`` bytes
    before compression); the metadata (settings, source, zone, exposure, match cutoff and window)
    is one JSON entry ``meta``.

    Raises
    ------
    TypeError
        If ``table`` is not a SpecularTable.
    OSError
        If the file cannot be written.
    """
    from vergence.io import atomic_write

    if not isinstance(table, SpecularTable):
        raise TypeError(f"table must be a SpecularTable; got {type(table).__name__}")
    a = table.analysis
    meta = {"format": TABLE_FORMAT, "version": _VERSION, "settings": table.settings, "source": table.source,
            "zone_arcmin": [table.zone.crossed_arcmin, table.zone.uncrossed_arcmin], "exposure": table.exposure,
            "epsilon_m": table.epsilon, "window": [int(v) for v in table.window], "analysis_seconds": a.seconds}  # fmt: skip
    arrays = {f"analysis_{name}": np.asarray(getattr(a, name)) for name in _ANALYSIS_ARRAYS}
    arrays |= _render_arrays("left", table.physical_left) | _render_arrays("right", table.right)
    path = Path(path)
    with atomic_write(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, meta=np.array(json.dumps(meta, allow_nan=False)), **arrays)
    return path


def _render(npz: Mapping, prefix: str) -> object:
    from vergence.camera import Camera
    from vergence.render.results import RenderResult, RenderSettings

    size = npz[f"{prefix}_size"]
    cam = Camera(K=npz[f"{prefix}_K"], R=npz[f"{prefix}_R"], t=npz[f"{prefix}_t"], width=int(size[0]),
                 height=int(size[1]))  # fmt: skip
    radiance = npz[f"{prefix}_radiance"]
    oid = npz[f"{prefix}_object_id"] if f"{prefix}_object_id" in npz else None
    return RenderResult(radiance=radiance, position=npz[f"{prefix}_position"], normal=npz[f"{prefix}_normal"],
                        depth=npz[f"{prefix}_depth"], beauty=radiance.sum(axis=0), camera=cam,
                        settings=RenderSettings(**json.loads(str(npz[f"{prefix}_settings"]))), object_id=oid)  # fmt: skip


def read_specular_table(path: str | Path) -> SpecularTable:
    """The table :func:`write_specular_table` stored at ``path``, every part checked.

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``.
    ValueError
        One line naming the file: damaged or truncated (a zip or CRC error, an array cut short),
        not a table (``format``), another version, a missing part, or parts that disagree (the
        analysis and the renders of another size or layer count, settings that do not match them).
    """
    from vergence.specular.display_fit import fit_display
    from vergence.viewing.geometry import Display

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    if not zipfile.is_zipfile(path):  # a truncated archive loses its central directory at the end
        raise ValueError(f"{path} is damaged or truncated, or no offset table: it is not a complete .npz (zip) archive")
    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {name: npz[name] for name in npz.files}  # reads (and CRC-checks) every array
    except (zipfile.BadZipFile, EOFError, OSError, ValueError, KeyError) as exc:
        raise ValueError(f"{path} is damaged or truncated, not a readable offset table ({type(exc).__name__}: "
                         f"{str(exc).splitlines()[0] if str(exc) else 'no detail'})") from None  # fmt: skip
    try:
        meta = json.loads(str(data["meta"]))
        if not isinstance(meta, dict) or meta.get("format") != TABLE_FORMAT:
            raise ValueError(f"its format is not {TABLE_FORMAT!r}")
        if meta.get("version") != _VERSION:
            raise ValueError(f"it is version {meta.get('version')!r}; this Vergence reads version {_VERSION}")
        settings = meta["settings"]
        d = settings["display"]
        screen = Display(eye_separation=d["eye_separation_m"], distance=d["viewing_distance_m"],
                         width=d["screen_width_m"], resolution=d["screen_width_px"])  # fmt: skip
        left, right = _render(data, "left"), _render(data, "right")
        display = fit_display(screen, left.camera.width, fit=d["fit"])
        arrays = {name: data[f"analysis_{name}"] for name in _ANALYSIS_ARRAYS}
        analysis = OffsetAnalysis(**arrays, exposure=float(meta["exposure"]), display=display,
                                  seconds=float(meta["analysis_seconds"]))  # fmt: skip
        k1, n = analysis.importance.shape[:2]
        if k1 != int(settings["k"]) + 1 or n != 2 ** (int(settings["max_depth"]) + 1) - 1:
            raise ValueError(f"its analysis has {k1} offsets and {n} layers; its settings say k = {settings['k']}, "
                             f"max_depth = {settings['max_depth']}")  # fmt: skip
        crossed, uncrossed = meta["zone_arcmin"]
        return SpecularTable(analysis=analysis, physical_left=left, right=right,
                             zone=ComfortZone(crossed_arcmin=crossed, uncrossed_arcmin=uncrossed),
                             exposure=float(meta["exposure"]), epsilon=float(meta["epsilon_m"]),
                             window=tuple(int(v) for v in meta["window"]), settings=settings,
                             source=dict(meta.get("source") or {}))  # fmt: skip
    except KeyError as exc:
        raise ValueError(f"{path} is not a complete offset table: {exc.args[0]!r} is missing") from None
    except (TypeError, ValueError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path} is not a valid offset table: {str(exc).splitlines()[0]}") from None
