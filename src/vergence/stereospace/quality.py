"""A quality value for a stereo pair of the stereospace (S2 §4.3.2 leaves it as future work).

Two measures of a pair of cameras (a region vertex: two cameras of the collection; or any two novel
cameras): the comfort of its disparities on a display, against the comfort zone of
:mod:`vergence.viewing`, and how far the Fusiello rectification (Fusiello et al. 2000) distorts the
images.
"""

from __future__ import annotations

import numpy as np

from vergence.camera import Camera
from vergence.depth import rectify_cameras
from vergence.stereospace.collection import Collection
from vergence.stereospace.orientation import collection_up, eye_order
from vergence.viewing import ComfortZone, Display, check_disparity_range, check_display

__all__ = ["DISPARITY_TRIM", "pair_quality"]

DISPARITY_TRIM = 0.01
"""Fraction of a pair's point disparities dropped at each end before its range is taken
(:func:`~vergence.stereospace.pair_quality`'s ``trim``): on dino the 1 % tails of a neighbouring
pair reach -175 and +142 px against -9.6 and +15.7 px at the 1st and 99th percentiles."""


def _seen(cam: Camera, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    xy, z = cam.project(points)
    inside = (z > 0) & (xy[:, 0] >= -0.5) & (xy[:, 0] <= cam.width - 0.5)
    inside &= (xy[:, 1] >= -0.5) & (xy[:, 1] <= cam.height - 0.5)
    return xy, inside


def _similarity_residual(src: np.ndarray, dst: np.ndarray) -> float:
    """RMS distance from ``dst`` to the best similarity image of ``src`` (Umeyama 1991, no reflection)."""
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - ms, dst - md
    # For 2D similarities z -> s e^{i theta} z + t on complex numbers: the least-squares factor is
    # sum(conj(a) b) / sum(|a|^2).
    za, zb = a[:, 0] + 1j * a[:, 1], b[:, 0] + 1j * b[:, 1]
    factor = np.vdot(za, zb) / np.vdot(za, za).real
    return float(np.sqrt(np.mean(np.abs(zb - factor * za) ** 2)))


def _distortion(T: np.ndarray, cam: Camera) -> float:
    """Departure of the homography ``T`` from a similarity over the image, a fraction of its diagonal."""
    gx, gy = np.meshgrid(np.linspace(-0.5, cam.width - 0.5, 9), np.linspace(-0.5, cam.height - 0.5, 9))
    src = np.stack([gx.ravel(), gy.ravel()], axis=1)
    h = np.concatenate([src, np.ones((len(src), 1))], axis=1) @ T.T
    dst = h[:, :2] / h[:, 2:3]
    return _similarity_residual(src, dst) / float(np.hypot(cam.width, cam.height))


def pair_quality(collection: Collection, cameras: tuple[Camera, Camera], display: Display, *,
                 zone: ComfortZone | None = None, trim: float = 0.0) -> dict:
    """The comfort and rectification distortion of a pair of cameras on a display.

    The two cameras are rectified together (Fusiello et al. 2000), the left being the one that keeps
    the rectified image upright in the collection's world up (:func:`~vergence.stereospace.eye_order`,
    as :func:`~vergence.stereospace.stereo_pair` orders them). The points of ``collection`` seen by both (in front of
    both and projecting inside both images) give the rectified disparities ``x_r - x_l`` (pixels);
    shown with each rectified image filling the display's width, a disparity of ``d`` image
    pixels is ``d * resolution / W`` screen pixels, converted to arcminutes and checked against
    ``zone`` by :func:`vergence.viewing.check_disparity_range`. The range ``max - min`` is what a
    horizontal image shift cannot change: ``fits_with_shift`` says whether it fits the zone's width.
    ``trim`` drops that fraction of the disparities at each end first (sparse SfM points hold a few
    outliers, which would otherwise set the range): the range is then from the ``trim`` to the
    ``1 - trim`` quantile.

    Returns
    -------
    dict
        ``points_seen`` (int), ``swapped`` (bool), ``disparity_px`` (min, max rectified image
        pixels), ``disparity_arcmin`` (min, max), ``range_arcmin``, ``zone_arcmin`` (min, max),
        ``comfort`` (the ComfortReport as a dict, None without points), ``inside`` (the unshifted
        range lies in the zone), ``fits_with_shift``, ``rectification_distortion`` (per view, the
        RMS departure of its homography from the best similarity over a 9 x 9 grid of the image,
        a fraction of the image diagonal: 0 for a pure similarity), ``rectification_rotation_deg``
        (per view, the angle of the rectifying rotation).

    Raises
    ------
    ValueError
        A pair that cannot be rectified (coincident centres, baseline along the viewing direction),
        a display without resolution.
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    if not (isinstance(cameras, tuple | list) and len(cameras) == 2 and all(isinstance(c, Camera) for c in cameras)):
        raise TypeError("cameras must be a pair of Camera instances")
    check_display(display, resolution=True)
    if isinstance(trim, bool) or not isinstance(trim, int | float) or not 0.0 <= trim < 0.5:
        raise ValueError(f"trim must be a fraction in [0, 0.5); got {trim!r}")
    zone = ComfortZone() if zone is None else zone
    if not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a ComfortZone; got {type(zone).__name__}")
    scale = display.resolution / cameras[0].width
    first, second = cameras
    up = collection_up(collection.cameras)
    swapped = eye_order(first, second, up)
    left, right = (second, first) if swapped else (first, second)
    rect = rectify_cameras(left, right, up=up)
    pts = collection.points
    xy_l, seen_l = _seen(left, pts)
    xy_r, seen_r = _seen(right, pts)
    both = seen_l & seen_r
    zone_min, zone_max = zone.min_arcmin, zone.max_arcmin
    out: dict = {"points_seen": int(both.sum()), "swapped": swapped, "zone_arcmin": (zone_min, zone_max)}
    angles = []
    for cam, new in ((left, rect.left_camera), (right, rect.right_camera)):
        cos = (np.trace(new.R @ cam.R.T) - 1.0) / 2.0
        angles.append(float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))))
    out["rectification_distortion"] = (_distortion(rect.left_homography, left), _distortion(rect.right_homography, right))
    out["rectification_rotation_deg"] = tuple(angles)
    if not both.any():
        out.update(disparity_px=None, disparity_arcmin=None, range_arcmin=None, comfort=None, inside=False,
                   fits_with_shift=False)
        return out
    xl, _ = rect.left_camera.project(pts[both])
    xr, _ = rect.right_camera.project(pts[both])
    disparity = xr[:, 0] - xl[:, 0]  # screen parallax convention x_r - x_l (vergence.viewing)
    if trim > 0.0:
        low, high = np.quantile(disparity, [trim, 1.0 - trim])
        disparity = disparity[(disparity >= low) & (disparity <= high)]
    report = check_disparity_range(disparity * scale, display, zone=zone)
    span = report.max_arcmin - report.min_arcmin
    out.update(disparity_px=(float(disparity.min()), float(disparity.max())),
               disparity_arcmin=(report.min_arcmin, report.max_arcmin), range_arcmin=span,
               comfort=report.to_dict(), inside=report.inside, fits_with_shift=bool(span <= zone_max - zone_min))
    return out
