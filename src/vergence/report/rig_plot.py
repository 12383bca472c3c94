"""Figure of a multi-camera rig seen from above: each camera a frustum wedge in the horizontal plane.

Used for the Quadri-Rig (S0 §5, Fig. 5) and the Tri-Rig (S0 §6, Fig. 7) by ``vergence rig plan
--plot`` and the demo. Two panels: the whole layout (cameras and the scene elements they aim at),
and a close-up on the camera centres. Equal aspect, metres on both axes. Drawn without pyplot state
and written atomically (:mod:`vergence.report._figures`) as PNG or SVG, chosen by the extension.

**The top view.** "Up" is the mean of the cameras' image-up axes ``-R[1]`` (rows of ``R``: right,
down, forward; :doc:`conventions`), normalised; the picture is the plane perpendicular to it. Its
horizontal axis ("across") is the mean of the cameras' right axes ``R[0]`` with its up component
removed, its vertical axis ("along") is ``up x across``, so the viewing direction points up the
page and each camera's right is to the right. Coordinates are ``p . across`` and ``p . along``
(metres from the world origin), so the figure reads in world units.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from types import MappingProxyType

import numpy as np

from vergence._validate import as_float_array, check_positive
from vergence.camera import Camera
from vergence.io import atomic_write

__all__ = ["FIGURE_FORMATS", "FIGURE_SIZE", "ROLE_COLORS", "frustum_wedge", "plot_rig", "top_view_basis"]

FIGURE_FORMATS = (".png", ".svg")
# Colours of the eyes, as an anaglyph shows them (red left, blue right); other roles are grey.
ROLE_COLORS = MappingProxyType({"left": "tab:red", "right": "tab:blue"})
_OTHER_COLOR = "0.35"
# Below this length a mean axis is taken to have cancelled out (cameras facing opposite ways).
_MIN_AXIS = 1e-6
# The wedges reach this much past the farthest element, as a share of its distance.
_REACH_MARGIN = 1.1
# Without elements the wedges reach this multiple of the cameras' spread, and at least _MIN_REACH m.
_REACH_SPREAD = 3.0
_MIN_REACH = 1.0
# Close-up margin around the camera centres: this share of their spread, and at least _MIN_PAD m.
_PAD_SHARE = 0.2
_MIN_PAD = 0.25
# Close-up room for the name rows, as a share of the cameras' extent along the view; the rows' heights
# in axes fractions (two staggered rows so that neighbouring names do not overlap).
_LABEL_ROOM = 0.35
_LABEL_ROWS = (0.02, 0.1)
FIGURE_SIZE = (12.0, 6.0)  # inches, at 100 dpi


def _unit(v: np.ndarray) -> np.ndarray | None:
    n = float(np.linalg.norm(v))
    return v / n if n > _MIN_AXIS else None


def top_view_basis(cameras: Sequence[Camera]) -> np.ndarray:
    """The top-view frame of a set of cameras: rows ``across``, ``along``, ``up`` (orthonormal).

    ``up`` is the normalised mean of the cameras' image-up axes ``-R[1]``; ``across`` the mean of
    their right axes ``R[0]`` made perpendicular to ``up``; ``along = up x across`` (the mean viewing
    direction when the cameras roughly agree). A point's top-view coordinates are
    ``basis[:2] @ p``.

    Raises
    ------
    TypeError
        If ``cameras`` is not a non-empty sequence of :class:`Camera`.
    ValueError
        If the image-up axes cancel out (no common up: no top view).

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> cam = look_at([0, 2, 0], [0, 2, -10], [0, 1, 0], fov_deg=40, width=64, height=48)
    >>> (top_view_basis([cam]).round(6) + 0.0).tolist()  # + 0.0: no negative zeros
    [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
    """
    if isinstance(cameras, str | bytes) or not isinstance(cameras, Sequence) or not cameras:
        raise TypeError("cameras must be a non-empty sequence of Camera")
    for i, cam in enumerate(cameras):
        if not isinstance(cam, Camera):
            raise TypeError(f"cameras[{i}] must be a Camera; got {type(cam).__name__}")
    R = np.stack([cam.R for cam in cameras])
    up = _unit(-R[:, 1].mean(axis=0))
    if up is None:
        raise ValueError("cameras' image-up axes -R[1] cancel out; there is no common up for a top view")
    across = _unit(_flat(R[:, 0].mean(axis=0), up))
    if across is None:  # right axes cancel out: take the viewing directions, else any horizontal axis
        along = _unit(_flat(R[:, 2].mean(axis=0), up))
        if along is None:
            along = _unit(_flat(np.eye(3)[int(np.argmin(np.abs(up)))], up))
        across = np.cross(along, up)
    return np.stack([across, np.cross(up, across), up])


def _flat(v: np.ndarray, up: np.ndarray) -> np.ndarray:
    return v - (v @ up) * up


def frustum_wedge(camera: Camera, basis: np.ndarray, *, reach: float) -> np.ndarray:
    """The camera's horizontal field of view in the top view: ``(3, 2)`` apex, left end, right end.

    The apex is the optical centre ``c = -R^T t``; the ends are the points at camera-frame depth
    ``reach`` on the rays through the left and right image edges (columns ``-0.5`` and
    ``width - 0.5``) at the principal point's row: ``c + reach R^T K^-1 (x, c_y, 1)``. A shifted
    principal point (S0 §2, the Quadri-Rig's cameras, SPEC §1.9) gives a lopsided wedge, as it should.

    Parameters
    ----------
    camera : Camera
    basis : (3, 3) array
        From :func:`top_view_basis` (rows across, along, up).
    reach : float, keyword-only
        Depth of the wedge's far edge in metres, > 0.

    Examples
    --------
    >>> from vergence.camera import look_at
    >>> cam = look_at([0, 0, 0], [0, 0, -1], [0, 1, 0], fov_deg=90, width=100, height=50)
    >>> frustum_wedge(cam, top_view_basis([cam]), reach=2.0).round(9).tolist()
    [[0.0, 0.0], [-2.0, 2.0], [2.0, 2.0]]
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a Camera; got {type(camera).__name__}")
    basis = as_float_array("basis", basis, shape=(3, 3))
    reach = check_positive("reach", reach)
    cy = camera.principal_point[1]
    edges = np.array([[-0.5, cy, 1.0], [camera.width - 0.5, cy, 1.0]])
    rays_cam = np.linalg.solve(camera.K, edges.T).T  # z = 1: a point at depth `reach` is reach * ray
    ends = camera.center + reach * rays_cam @ camera.R  # R^T applied to each row
    points = np.vstack([camera.center, ends])
    return points @ basis[:2].T


def _entries(name: str, items: object) -> list[tuple[str, Camera, str]]:
    """``items`` as (name, Camera, role): tuples ``(name, camera, role)`` or objects with ``.name``,
    ``.camera``, ``.eye`` (:class:`vergence.rigs.RigCamera`)."""
    if isinstance(items, str | bytes) or not isinstance(items, Sequence):
        raise TypeError(f"{name} must be a sequence of (name, Camera, role) or RigCamera; got {type(items).__name__}")
    out = []
    for i, item in enumerate(items):
        if isinstance(item, tuple | list) and len(item) == 3:
            label, cam, role = item
        elif all(hasattr(item, a) for a in ("name", "camera", "eye")):
            label, cam, role = item.name, item.camera, item.eye
        else:
            raise TypeError(f"{name}[{i}] must be (name, Camera, role) or have .name, .camera, .eye; "
                            f"got {type(item).__name__}")  # fmt: skip
        if not isinstance(label, str) or not label:
            raise TypeError(f"{name}[{i}] name must be a non-empty str; got {label!r}")
        if not isinstance(cam, Camera):
            raise TypeError(f"{name}[{i}] camera must be a Camera; got {type(cam).__name__}")
        if not isinstance(role, str):
            raise TypeError(f"{name}[{i}] role must be a str; got {type(role).__name__}")
        out.append((label, cam, role))
    return out


def _elements(items: object) -> list[tuple[str, np.ndarray]]:
    if isinstance(items, str | bytes) or not isinstance(items, Sequence):
        raise TypeError(f"elements must be a sequence of (name, point); got {type(items).__name__}")
    out = []
    for i, item in enumerate(items):
        if not isinstance(item, tuple | list) or len(item) != 2 or not isinstance(item[0], str):
            raise TypeError(f"elements[{i}] must be a (name, point) pair with a str name; got {item!r}")
        out.append((item[0], as_float_array(f"elements[{i}] point", item[1], shape=(3,))))
    return out


def _figure_path(path: object) -> Path:
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"path must be a str or a path; got {type(path).__name__}")
    out = Path(path)
    if out.suffix.lower() not in FIGURE_FORMATS:
        raise ValueError(f"path must end in {' or '.join(FIGURE_FORMATS)}; got {str(path)!r}")
    return out


def _draw(ax, entries, basis, reach, *, dashed: bool) -> None:
    from matplotlib.patches import Polygon

    for _name, cam, role in entries:
        color = ROLE_COLORS.get(role, _OTHER_COLOR)
        wedge = frustum_wedge(cam, basis, reach=reach)
        ls = "--" if dashed else "-"
        ax.add_patch(Polygon(wedge, closed=True, facecolor=color, alpha=0.06 if dashed else 0.1, lw=0))
        ax.plot(wedge[[1, 0, 2], 0], wedge[[1, 0, 2], 1], color=color, lw=1.0, ls=ls)
        axis_end = (cam.center + reach * cam.R[2]) @ basis[:2].T  # the optical axis, dotted
        ax.plot([wedge[0, 0], axis_end[0]], [wedge[0, 1], axis_end[1]], color=color, lw=0.6, ls=":")
        ax.plot(*wedge[0], marker="s" if dashed else "o", ms=4, color=color, mfc="white" if dashed else color)


def _label_rows(ax, entries, basis, *, top: bool) -> None:
    """Names in two staggered rows along the bottom (real) or top (virtual) edge, with leader lines.

    Cameras often stand centimetres apart; evenly spaced slots, ordered across, keep names apart.
    """
    items = sorted(((cam.center @ basis[:2].T, name, ROLE_COLORS.get(role, _OTHER_COLOR)) for name, cam, role in entries),
                   key=lambda item: item[0][0])  # fmt: skip
    for k, (q, name, color) in enumerate(items):
        row = _LABEL_ROWS[k % 2]
        ax.annotate(name, q, xytext=((k + 0.5) / len(items), 1.0 - row if top else row), textcoords="axes fraction",
                    ha="center", va="top" if top else "bottom", fontsize=7, color=color,
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85},
                    arrowprops={"arrowstyle": "-", "color": color, "lw": 0.5, "alpha": 0.7})  # fmt: skip


def plot_rig(
    path: str | os.PathLike[str],
    cameras: Sequence,
    *,
    elements: Sequence = (),
    virtual: Sequence = (),
    title: str | None = None,
    reach: float | None = None,
) -> Path:
    """Draw a rig from above (frustum wedges, names, elements); write a PNG or SVG atomically.

    Real cameras are solid wedges, virtual ones (the Quadri-Rig's virtual eyes, S0 §5) dashed; the
    colour is the role (``"left"`` red, ``"right"`` blue, anything else grey, :data:`ROLE_COLORS`);
    a dotted line is each optical axis (off the wedge's middle for a shifted sensor). The top-view
    plane is described in the module docstring (:func:`top_view_basis`, from the real and virtual
    cameras together). Left panel: the whole layout with the elements; right panel: the camera centres.

    Parameters
    ----------
    path : str or os.PathLike
        Output file ending in ``.png`` or ``.svg`` (:data:`FIGURE_FORMATS`); its folder must exist.
    cameras : sequence
        Non-empty; each ``(name, Camera, role)`` or an object with ``.name``, ``.camera`` and
        ``.eye`` (:class:`vergence.rigs.RigCamera`, whose eye is the role).
    elements : sequence of (name, point), keyword-only
        Scene points the rig aims at (world metres), drawn as labelled crosses.
    virtual : sequence, keyword-only
        Virtual cameras, in the same forms as ``cameras``; drawn dashed.
    title : str or None, keyword-only
        Figure title (default: ``"Rig from above: N cameras"``).
    reach : float or None, keyword-only
        Camera-frame depth of the wedges' far edges in metres; default 1.1 x the farthest element's
        distance along the view, or without elements 3 x the cameras' spread (at least 1 m).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    TypeError
        A wrong type for any argument or entry.
    ValueError
        ``cameras`` empty, ``path`` with another extension, a non-finite element point or
        ``reach``, or cameras with no common up.
    FileNotFoundError
        If the folder of ``path`` does not exist.
    """
    out = _figure_path(path)
    real = _entries("cameras", cameras)
    if not real:
        raise ValueError("cameras must hold at least one camera; got none")
    virt = _entries("virtual", virtual)
    points = _elements(elements)
    if title is not None and not isinstance(title, str):
        raise TypeError(f"title must be a str or None; got {type(title).__name__}")
    basis = top_view_basis([cam for _, cam, _ in real + virt])
    centres = np.array([cam.center for _, cam, _ in real + virt]) @ basis[:2].T
    if reach is None:
        mid = np.array([cam.center for _, cam, _ in real + virt]).mean(axis=0)
        spread = float(np.ptp(centres, axis=0).max())
        along = [float((p - mid) @ basis[1]) for _, p in points]
        far = max(along, default=0.0)
        reach = _REACH_MARGIN * far if far > 0 else max(_MIN_REACH, _REACH_SPREAD * spread)
    reach = check_positive("reach", reach)

    from vergence.report._figures import new_figure

    fig = new_figure(figsize=FIGURE_SIZE, dpi=100)
    ax_all, ax_near = fig.subplots(1, 2, width_ratios=(1.0, 1.6))
    fig.suptitle(title if title is not None else f"Rig from above: {len(real)} camera(s)", fontsize=10)
    lo, hi = centres.min(axis=0), centres.max(axis=0)
    pad = max(_MIN_PAD, _PAD_SHARE * float((hi - lo).max()))
    span = hi[1] - lo[1] + 2 * pad
    room = _LABEL_ROOM * span
    # Close-up wedges stop about the top of the close-up, so that equal aspect fills the panel.
    for ax, length_real, length_virtual in ((ax_all, reach, reach), (ax_near, span, pad + room)):
        _draw(ax, virt, basis, length_virtual, dashed=True)
        _draw(ax, real, basis, length_real, dashed=False)
        ax.set_xlabel("across (m)")
        ax.set_ylabel("along the view (m)")
        ax.grid(True, alpha=0.3)
    for name, p in points:
        q = p @ basis[:2].T
        ax_all.plot(*q, marker="x", ms=7, mew=1.8, color="tab:green")
        ax_all.annotate(name, q, xytext=(5, 3), textcoords="offset points", fontsize=8, color="tab:green")
    ax_all.set_title("layout", fontsize=9)
    # The close-up: camera centres with room below (and above, for virtual cameras) for the name rows.
    ax_near.update_datalim([[lo[0] - pad, lo[1] - pad - room], [hi[0] + pad, hi[1] + pad + (room if virt else 0.0)]])
    ax_near.set_title("camera centres (solid: real, dashed: virtual)", fontsize=9)
    _label_rows(ax_near, real, basis, top=False)
    if virt:
        _label_rows(ax_near, virt, basis, top=True)
    for ax in (ax_all, ax_near):
        ax.set_aspect("equal", adjustable="datalim")
        ax.autoscale_view()
    handles = [ax_near.plot([], [], color=c, label=f"{r} eye")[0] for r, c in ROLE_COLORS.items()]
    handles.append(ax_near.plot([], [], color=_OTHER_COLOR, label="other")[0])
    handles.append(ax_near.plot([], [], color="0.35", ls="--", label="virtual")[0])
    ax_near.legend(handles=handles, loc="best", fontsize=7)
    ax_all.text(0.01, 0.01, f"wedges to depth {reach:.3g} m", transform=ax_all.transAxes, fontsize=7, color="0.4")
    with atomic_write(out) as tmp:
        fmt = out.suffix.lower()[1:]
        fig.savefig(tmp, format=fmt, metadata={"Date": None} if fmt == "svg" else None)  # SVG: no date, same bytes
    return out
