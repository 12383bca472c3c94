"""The two baselines S3 §4.1 compares with: specular layers shown *on* or *near* the surface they appear on.

S3 §4.1 (Fig. 8 and the study of §4.2) sets its per-pixel camera offsets (S3 §3.4,
:func:`~vergence.specular.render_offsets`) against

- *on-surface* disparity: every reflection and refraction layer carries the disparity of the surface
  it is seen on, so that "the mirror appear[s] as flat as a diffuse poster" (:func:`on_surface`);
- *near-surface* disparity: "a small constant offset of reflection/refraction layers, which places
  them near the surface of the objects, in a similar fashion to the solution proposed for
  reflections by Templin et al. [2012]" (:func:`near_surface`). S3 gives no value for the offset;
  :data:`NEAR_SURFACE_ARCMIN` (5′) is our choice.

Both are post-processes of a physical stereo ray tree (two :class:`vergence.render.RenderResult`
of a shifted-sensor rig, :func:`vergence.rigs.stereo_pair`): the right eye is kept, and the left
eye's specular layers are *texture-mapped* from the right eye onto the left eye's first hit.
For left pixel ``p`` whose first hit (layer 0) is the world point ``S``, ``(u, v)`` is the
projection of ``S`` in the right camera and the new left layer ``i >= 1`` at ``p`` is the right
eye's layer ``i`` bilinearly sampled at ``(u, v)`` (on-surface) or ``(u + s delta_px, v)``
(near-surface). A pattern the right eye shows at ``(u, v)`` is then shown by the left eye at
``p``: it has exactly the screen parallax of ``S`` (plus ``s delta_px``), whatever depth the
reflected or refracted scene has. Geometry (positions, normals, depth) is the left eye's: only the
shading moves.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from vergence._validate import check_finite
from vergence.specular.matching import layer_disparity
from vergence.specular.offsets import check_rig
from vergence.viewing.comfort import MAX_VERGENCE_ARCMIN, pixels_from_arcmin
from vergence.viewing.geometry import Display, check_display

if TYPE_CHECKING:  # importing vergence.render imports Mitsuba: only when a result is checked
    from vergence.render import RenderResult

__all__ = ["NEAR_SURFACE_ARCMIN", "SAME_SURFACE_FRACTION", "near_surface", "on_surface"]

#: Offset of the near-surface baseline, arcminutes of vergence: our choice, not S3's (S3 §4.1 says
#: only "a small constant offset"). 5′ is about 3.1 display pixels on S3's study display (1680 px,
#: 0.282 mm pitch, 60 cm), a twelfth of the common ±60′ comfort zone (vergence.viewing.ComfortZone).
NEAR_SURFACE_ARCMIN = 5.0

#: Same-surface test of the texture mapping, as a fraction of the distance from the left eye's point to
#: the right camera's centre: the right eye sees the left eye's surface point ``S`` when the point
#: ``P`` it sees at the nearest pixel lies within this distance of ``S``'s tangent plane and ``S``
#: within it of ``P``'s (see :func:`on_surface`, Notes). Our choice: the 1/100 of S3's matching
#: cutoff (:data:`~vergence.specular.EPSILON_FRACTION`, of the scene diameter), here of the point's
#: distance; a flat surface passes at float32 rounding of its points (about 1e-7 relative).
SAME_SURFACE_FRACTION = 0.01


def _check_pair(left: object, right: object) -> tuple[RenderResult, RenderResult]:
    """Two RenderResults of the same tree shape from a shifted-sensor rig, or a one-line error."""
    from vergence.render import RenderResult

    for name, res in (("left", left), ("right", right)):
        if not isinstance(res, RenderResult):
            raise TypeError(f"{name} must be a vergence.render.RenderResult; got {type(res).__name__}")
    if left.radiance.shape != right.radiance.shape:
        raise ValueError(f"right must have the layers and size of left (N, H, W, 3) = {left.radiance.shape}; "
                         f"got {right.radiance.shape}")  # fmt: skip
    check_rig(left.camera, right.camera)
    return left, right


def check_offset_arcmin(offset_arcmin: object) -> float:
    offset = check_finite("offset_arcmin", offset_arcmin)
    if not 0.0 <= offset <= MAX_VERGENCE_ARCMIN:
        raise ValueError(f"offset_arcmin must lie in [0, {MAX_VERGENCE_ARCMIN:g}] arcmin (a vergence change of at "
                         f"most 180 degrees); got {offset:g}")  # fmt: skip
    return offset


def _surface_lookup(left: RenderResult, right: RenderResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``u``, ``v`` (H, W) float64: the left first hits projected in the right camera, and ``seen`` (H, W)
    bool: where they fall on the image (``-0.5 <= u <= W - 0.5``, likewise ``v``) and the right eye
    sees the same surface at the nearest pixel (:data:`SAME_SURFACE_FRACTION`)."""
    h, w = left.camera.height, left.camera.width
    s = left.position[0].astype(np.float64)  # (H, W, 3), NaN where the primary ray escapes
    cam = right.camera
    x_cam = s @ cam.R.T + cam.t  # as Camera.project, which refuses NaN points
    z = x_cam[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        proj = x_cam @ cam.K.T
        u, v = proj[..., 0] / proj[..., 2], proj[..., 1] / proj[..., 2]
        inside = (z > 0) & (np.abs(u - (w - 1) / 2) <= w / 2) & (np.abs(v - (h - 1) / 2) <= h / 2)  # NaN: False
    qx = np.clip(np.where(inside, np.rint(u), 0), 0, w - 1).astype(np.intp)
    qy = np.clip(np.where(inside, np.rint(v), 0), 0, h - 1).astype(np.intp)
    p = right.position[0][qy, qx].astype(np.float64)
    n_p = right.normal[0][qy, qx].astype(np.float64)
    n_s = left.normal[0].astype(np.float64)
    tol = SAME_SURFACE_FRACTION * np.linalg.norm(s - right.camera.center, axis=-1)
    with np.errstate(invalid="ignore"):
        gap = p - s
        same = (np.abs(np.sum(n_s * gap, axis=-1)) <= tol) & (np.abs(np.sum(n_p * gap, axis=-1)) <= tol)
    return u, v, inside & same


def _bilinear(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``image`` (N, H, W, 3) sampled bilinearly at ``(x, y)`` (N, H, W), float64; coordinates are clamped to
    ``[0, W-1] x [0, H-1]`` (the edge pixels repeat, as OpenCV's ``BORDER_REPLICATE``)."""
    n, h, w = image.shape[:3]
    x = np.clip(x, 0, w - 1)
    y = np.clip(y, 0, h - 1)
    x0 = np.floor(x).astype(np.intp)
    y0 = np.floor(y).astype(np.intp)
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    layer = np.arange(n)[:, None, None]
    img = image.astype(np.float64)
    top = (1.0 - fx) * img[layer, y0, x0] + fx * img[layer, y0, x1]
    bottom = (1.0 - fx) * img[layer, y1, x0] + fx * img[layer, y1, x1]
    return (1.0 - fy) * top + fy * bottom


def _texture_map(left: RenderResult, right: RenderResult, shift_px: np.ndarray) -> RenderResult:
    """The left eye with layers ``1..N-1`` sampled from the right eye at ``(u + shift_px, v)`` ((N-1, H, W))."""
    n, h, w = left.radiance.shape[:3]
    if n == 1:
        return left
    u, v, seen = _surface_lookup(left, right)
    x = u[None] + shift_px  # (N - 1, H, W)
    y = np.broadcast_to(v, x.shape)
    with np.errstate(invalid="ignore"):
        use = seen[None] & (np.abs(x - (w - 1) / 2) <= w / 2)
    sampled = _bilinear(right.radiance[1:], np.where(use, x, 0.0), np.where(use, y, 0.0))
    radiance = np.array(left.radiance, dtype=np.float32, copy=True)
    radiance[1:] = np.where(use[..., None], sampled, radiance[1:])
    return replace(left, radiance=radiance, beauty=radiance.sum(axis=0))


def on_surface(left: RenderResult, right: RenderResult) -> RenderResult:
    """The left eye with its specular layers mapped from the right eye onto its first hit (S3 §4.1, on-surface).

    Parameters
    ----------
    left, right : vergence.render.RenderResult
        The physical ray trees of the two eyes of a shifted-sensor rig
        (:func:`vergence.rigs.stereo_pair`: same ``R``, size and ``K`` but ``cx``), of the same
        depth (``N = 2^(D+1) - 1`` layers, heap order: layer 0 the first hit).

    Returns
    -------
    RenderResult
        ``left`` with its radiance of layers ``i >= 1`` replaced, at every pixel ``p`` whose first hit
        ``S`` the right eye sees, by the right eye's layer ``i`` sampled bilinearly at the projection
        ``(u, v)`` of ``S`` in the right camera; ``beauty`` is the new sum of the layers. Layer 0,
        positions, normals, depth, camera and settings are ``left``'s. ``left`` itself when ``N = 1``
        (no specular layer).

    Raises
    ------
    TypeError
        If ``left`` or ``right`` is not a RenderResult, or a camera is not a pinhole Camera.
    ValueError
        If the two trees differ in depth or size, or the cameras are not a shifted-sensor rig.

    Notes
    -----
    The right eye shows at ``(u, v)`` what the left now shows at ``p``, and ``(u, v)`` is where the
    surface point ``S`` seen at ``p`` appears in the right eye: every specular layer has the
    screen disparity of the first surface, ``x_l - x_r = p_x - u`` (S3 §4.1: the mirror looks "as
    flat as a diffuse poster"). Layer 0 needs no mapping: it already has that disparity.

    ``left``'s own (physical) layer is kept at ``p`` where

    - the first ray escapes (no ``S``) or ``S`` is behind the right camera,
    - ``(u, v)`` lies outside the image, ``[-0.5, W - 0.5] x [-0.5, H - 0.5]`` (the pixels' areas,
      centres at integers); within half a pixel of its edge the edge pixels are repeated,
    - the right eye sees another surface there: with ``P`` the right eye's first hit at the pixel
      nearest ``(u, v)`` and ``n_S``, ``n_P`` the two unit normals, it needs
      ``|n_S . (P - S)| <= f |S - c_R|`` and ``|n_P . (P - S)| <= f |S - c_R|``, ``f`` =
      :data:`SAME_SURFACE_FRACTION`, ``c_R`` the right camera's centre. Each point must lie near the
      other's tangent plane: a flat surface passes however slanted (a plain distance ``|P - S|``
      fails a grazing floor, whose neighbouring pixels lie far apart), an occluder in front of ``S``
      fails the first test, and the silhouette of a curved occluder, whose tangent plane contains
      the right eye's ray and so nearly ``S``, fails the first too.

    Sampling of the right eye's layer is exact bilinear interpolation in float64 (stored as float32),
    not OpenCV's ``remap``, whose weights are quantised to 1/32 pixel.

    Examples
    --------
    A right eye with no specular layer leaves the left eye as it is; see
    ``tests/specular/test_surface_baselines.py`` for a flat textured mirror.
    """
    left, right = _check_pair(left, right)
    n, h, w = left.radiance.shape[:3]
    return _texture_map(left, right, np.zeros((n - 1, h, w)))


def near_surface(
    left: RenderResult, right: RenderResult, display: Display, *, offset_arcmin: float = NEAR_SURFACE_ARCMIN
) -> RenderResult:
    """As :func:`on_surface`, each specular layer a constant offset off the surface (S3 §4.1, near-surface).

    Parameters
    ----------
    left, right : vergence.render.RenderResult
        As :func:`on_surface`.
    display : vergence.viewing.Display
        The viewing set-up (its ``resolution`` must be known); the image fills its width.
    offset_arcmin : float, keyword-only
        The offset, arcminutes of vergence, finite, in ``[0, 10800]``; default
        :data:`NEAR_SURFACE_ARCMIN` (5′, our choice: S3 gives none). 0 gives :func:`on_surface`.

    Returns
    -------
    RenderResult
        As :func:`on_surface`, with layer ``i >= 1`` at ``p`` sampled from the right eye at
        ``(u + s delta_px, v)``: its screen parallax ``x_r - x_l`` is the surface's plus
        ``s delta_px`` image pixels.

    Raises
    ------
    TypeError
        As :func:`on_surface`; ``display`` not a Display or ``offset_arcmin`` not a real number.
    ValueError
        As :func:`on_surface`; the display resolution unknown or ``offset_arcmin`` NaN, inf,
        negative or past 10800′.

    Notes
    -----
    ``delta_px`` is the parallax whose vergence change at the screen centre is ``offset_arcmin``
    (the exact form of :func:`vergence.viewing.pixels_from_arcmin`), in image pixels
    (``x W / display.resolution``): one constant screen parallax for the whole image, as S3's
    "small constant offset" (and Templin et al. 2012's constant shift of highlights). Its angle
    is ``offset_arcmin`` exactly for a surface on the screen plane, nearly so near it.

    ``s = +1`` (behind the surface) where the layer is physically behind the first surface,
    ``-1`` in front: the sign of ``(x_r - x_l)_i - (x_r - x_l)_0`` from
    :func:`~vergence.specular.layer_disparity` of the two eyes' positions (S3 §3.2 matching,
    default window and cutoff); ``+1`` on a tie and where either layer has no match. Where the
    shifted point leaves the image, or :func:`on_surface` keeps the physical layer, the physical
    layer is kept. Across a material edge the shifted sample may read the neighbouring material:
    the artefacts S3 §4.2 blames for the near-surface method's low ranks ("not accounting for
    sharp transitions in material properties").

    Examples
    --------
    On S3's study display 5′ is about 3.1 display pixels; an image 64 px wide shows it as

    >>> from vergence.viewing import Display, pixels_from_arcmin
    >>> round(float(pixels_from_arcmin(NEAR_SURFACE_ARCMIN, Display.preset("samsung-2233rz"))) * 64 / 1680, 3)
    0.118
    """
    left, right = _check_pair(left, right)
    display = check_display(display, resolution=True)
    offset = check_offset_arcmin(offset_arcmin)
    n, h, w = left.radiance.shape[:3]
    if n == 1:
        return left
    delta_px = float(pixels_from_arcmin(offset, display)) * w / display.resolution
    disp = layer_disparity(left.position, right.position).disparity_px[..., 0]  # x_l - x_r, NaN: no match
    with np.errstate(invalid="ignore"):
        in_front = -disp[1:] < -disp[0][None]  # parallax x_r - x_l of the layer below the surface's; NaN: False
    sign = np.where(in_front, -1.0, 1.0)
    return _texture_map(left, right, sign * delta_px)
