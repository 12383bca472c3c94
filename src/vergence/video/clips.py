"""Test clips with known truth: camera moves through the built-in scenes, rendered left + right + depth.

:func:`make_test_clips` renders two shots with a cut between them (``tabletop``, then ``stadium``),
each a sideways camera move, with the shifted-sensor rig of :func:`vergence.rigs.stereo_pair`, and
writes them as a full side-by-side stereo video and as an iw3-style RGBD video (colour left, 8-bit
inverse depth right, normalised per shot), with the truth of every frame in an ``.npz``: the left view's disparity
``x_left - x_right`` (px, :func:`vergence.render.screen_disparity`) and metric depth, and the
frame where each shot starts. The truth is exact; the videos are H.264 (lossy, ``crf``).

The truth of a retargeted clip is known too. :func:`vergence.video.convert_clip` maps each shot's
nearness with one linear psi, so its output parallax is ``P = a / z + b``: the parallax of a
shifted-sensor rig with another baseline and convergence distance. :func:`retargeted_rig` gives that
rig and :func:`render_retargeted` renders the shot through it, keeping the left camera of the clip
(``origin="left"``): the converted right view can then be compared with a direct render
(``benchmarks/video_retarget_truth.py``).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vergence.video.layout import layout_video_name

if TYPE_CHECKING:
    from vergence.camera import Camera
    from vergence.viewing.mapping_operators import LinearMapping

__all__ = ["CLIP_SHOTS", "VISIBLE_RTOL", "ClipShot", "RetargetedViews", "TestClips", "make_test_clips",
           "render_retargeted", "retargeted_rig"]

# A right-view pixel is seen by the left view when the left depth at its match brackets its own depth
# within this relative tolerance (the floor and ceil pixels of the match; a depth edge jumps by far more).
VISIBLE_RTOL = 0.01


@dataclass(frozen=True, slots=True)
class ClipShot:
    """One shot of the test clips: a built-in scene, its rig, and the camera's sideways travel.

    ``travel`` (metres) moves the scene camera and its look-at point from ``-travel/2`` to
    ``+travel/2`` along the world x axis over the shot.
    """

    scene: str
    baseline: float
    convergence: float
    travel: float


# The two shots: a close tabletop (crossed and uncrossed disparity around the mug, about +-6 px at
# 160 px wide) and a long-lens stadium whose bleachers lie far behind the convergence plane (about
# -10 px: beyond the divergence limit of a 55-inch TV).
CLIP_SHOTS = (
    ClipShot(scene="tabletop", baseline=0.1, convergence=1.2, travel=0.3),
    ClipShot(scene="stadium", baseline=0.5, convergence=30.0, travel=2.0),
)


@dataclass(frozen=True, slots=True)
class TestClips:
    """What :func:`make_test_clips` wrote.

    Attributes
    ----------
    stereo : pathlib.Path
        The full side-by-side video (``*_LRF_Full_SBS.mp4``).
    rgbd : pathlib.Path
        The colour + inverse depth video (``*_RGBD.mp4``): 8-bit ``v = (1/z - 1/far) / (1/near - 1/far)``, near and far per shot.
    truth : pathlib.Path
        ``.npz``: ``disparity`` (n, H, W) float32 px, ``depth`` (n, H, W) float32 m, ``cuts`` (the
        first frame of each shot after the first), ``near`` and ``far`` (per shot, m) of the RGBD depth.
    frames, width, height : int
        Frame count and size of one view.
    cuts : tuple of int
        First frame of each shot after the first.
    """

    __test__ = False  # not a pytest class despite its name

    stereo: Path
    rgbd: Path
    truth: Path
    frames: int
    width: int
    height: int
    cuts: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class _Rendered:
    lefts: list
    rights: list
    disparities: list  # x_left - x_right, px, at each left pixel
    depths: list  # left camera z, m
    right_depths: list  # right camera z, m
    focal_px: float


def _render_shot(shot: ClipShot, frames: int, width: int, height: int, retarget: ClipShot | None = None) -> _Rendered:
    """Render ``shot``; with ``retarget``, the right camera is that rig's, its left camera the shot's."""
    from vergence.render import Tracer, auto_exposure, builtin_scene, screen_disparity, tonemap
    from vergence.rigs import stereo_pair

    scene = builtin_scene(shot.scene, width=width, height=height)
    tracer = Tracer(scene)
    out = _Rendered([], [], [], [], [], scene.camera.build().focal_px)
    exposure = None
    for k in range(frames):
        dx = shot.travel * (k / max(frames - 1, 1) - 0.5)
        move = np.array([dx, 0.0, 0.0])
        cam = dataclasses.replace(scene.camera, position=scene.camera.position + move,
                                  look_at=scene.camera.look_at + move).build()  # fmt: skip
        left_cam, right_cam = stereo_pair(cam, baseline=shot.baseline, convergence=shot.convergence)
        if retarget is not None:
            right_cam = _right_camera(left_cam, retarget.baseline, retarget.convergence)
        left = tracer.render(left_cam, max_depth=0, samples=4)
        right = tracer.render(right_cam, max_depth=0, samples=4)
        if exposure is None:  # one exposure per shot: no flicker
            exposure = auto_exposure(left.beauty)
        out.lefts.append(tonemap(left.beauty, exposure=exposure))
        out.rights.append(tonemap(right.beauty, exposure=exposure))
        out.disparities.append(screen_disparity(left, right).astype(np.float32))
        out.depths.append(np.asarray(left.depth, dtype=np.float32))
        out.right_depths.append(np.asarray(right.depth, dtype=np.float32))
    return out


def _right_camera(left: Camera, baseline: float, convergence: float) -> Camera:
    """The right camera of the shifted-sensor rig (``baseline``, ``convergence``) whose left camera is ``left``.

    :func:`vergence.rigs.stereo_pair` of the rig's centre camera: ``left`` moved ``baseline / 2`` along
    its right axis, principal point ``cx + fx baseline / (2 convergence)`` (S0 §2).
    """
    from vergence.camera import Camera
    from vergence.rigs import stereo_pair

    center = left.center + 0.5 * baseline * left.R[0]
    K = np.array(left.K, copy=True)
    K[0, 2] += left.focal_px * baseline / (2.0 * convergence)
    middle = Camera(K=K, R=left.R, t=-left.R @ center, width=left.width, height=left.height)
    return stereo_pair(middle, baseline=baseline, convergence=convergence)[1]


def _seen_by_left(depth_left: np.ndarray, depth_right: np.ndarray, focal_px: float, baseline: float,
                  convergence: float) -> np.ndarray:  # fmt: skip
    """``(..., H, W)`` bool: right-view pixels whose point the left view sees (:attr:`RetargetedViews.visible`).

    A right pixel ``x_r`` of depth ``z`` is at ``x_l = x_r - P``, ``P = f b (1/H - 1/z)``; seen when
    ``x_l`` lies within the left view and the left depths at ``floor(x_l)`` and ``ceil(x_l)`` bracket
    ``z`` within :data:`VISIBLE_RTOL`. Unknown depth (NaN) is not seen.
    """
    width = depth_right.shape[-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        x_left = np.arange(width, dtype=np.float64) - focal_px * baseline * (1.0 / convergence - 1.0 / depth_right)
    inside = np.isfinite(x_left) & (x_left >= -0.5) & (x_left <= width - 0.5)
    x_left = np.where(inside, x_left, 0.0)
    j0 = np.clip(np.floor(x_left), 0, width - 1).astype(np.intp)
    j1 = np.clip(np.ceil(x_left), 0, width - 1).astype(np.intp)
    z0, z1 = np.take_along_axis(depth_left, j0, axis=-1), np.take_along_axis(depth_left, j1, axis=-1)
    low, high = np.fmin(z0, z1) * (1.0 - VISIBLE_RTOL), np.fmax(z0, z1) * (1.0 + VISIBLE_RTOL)
    return inside & (depth_right >= low) & (depth_right <= high)


def make_test_clips(folder: str | os.PathLike[str], *, frames_per_shot: int = 12, width: int = 160, height: int = 90,
                    crf: int = 12, name: str = "clips", shots: tuple[ClipShot, ...] = CLIP_SHOTS) -> TestClips:  # fmt: skip
    """Render the shots of ``shots`` and write the stereo video, the RGBD video and the truth into ``folder``.

    Parameters
    ----------
    folder : str or os.PathLike
        An existing folder.
    frames_per_shot : int
        Frames of each shot, >= 2.
    width, height : int
        Size of one view, even (H.264 4:2:0).
    crf : int
        x264 quality of both videos (0 = lossless).
    name : str
        Stem of the file names.
    shots : tuple of ClipShot
        Default :data:`CLIP_SHOTS`.

    Returns
    -------
    TestClips

    Examples
    --------
    ``python examples/video/make_clips.py OUT`` writes the clips of the README's figures.
    """
    from vergence.io import atomic_write
    from vergence.video.writer import VideoWriter

    if isinstance(frames_per_shot, bool) or not isinstance(frames_per_shot, int) or frames_per_shot < 2:
        raise ValueError(f"frames_per_shot must be an integer >= 2; got {frames_per_shot!r}")
    out = Path(folder)
    if not out.is_dir():
        raise FileNotFoundError(f"folder {out} does not exist")
    rendered = [_render_shot(s, frames_per_shot, width, height) for s in shots]
    disparity = np.stack([d for r in rendered for d in r.disparities])
    depth = np.stack([d for r in rendered for d in r.depths])
    # iw3 normalises the inverse depth per frame; here per shot (no flicker within a shot, and the far
    # stadium keeps its levels instead of sharing 8 bits with the tabletop).
    near = np.array([np.nanmin(np.stack(r.depths)) for r in rendered], dtype=np.float64)
    far = np.array([np.nanmax(np.stack(r.depths)) for r in rendered], dtype=np.float64)
    stereo_path = out / layout_video_name(name, "sbs")
    rgbd_path = out / layout_video_name(name, "rgbd")
    with VideoWriter(stereo_path, fps=24, width=2 * width, height=height, crf=crf) as stereo, \
            VideoWriter(rgbd_path, fps=24, width=2 * width, height=height, crf=crf) as rgbd:  # fmt: skip
        for r, z_near, z_far in zip(rendered, near, far):
            for left, right, z in zip(r.lefts, r.rights, r.depths):
                stereo.write(np.concatenate([left, right], axis=1))
                inverse = (1.0 / z - 1.0 / z_far) / (1.0 / z_near - 1.0 / z_far)
                grey = np.repeat(np.clip(np.nan_to_num(inverse, nan=0.0), 0.0, 1.0)[:, :, None], 3, axis=2)
                rgbd.write(np.concatenate([left, grey], axis=1))
    cuts = tuple(int(frames_per_shot * k) for k in range(1, len(shots)))
    truth_path = out / f"{name}_truth.npz"
    with atomic_write(truth_path) as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, disparity=disparity, depth=depth, cuts=np.array(cuts, dtype=np.int64),
                            near=near, far=far)  # fmt: skip
    return TestClips(stereo=stereo_path, rgbd=rgbd_path, truth=truth_path, frames=int(disparity.shape[0]),
                     width=width, height=height, cuts=cuts)  # fmt: skip


def retargeted_rig(shot: ClipShot, mapping: LinearMapping, *, focal_px: float, kind: str,
                   near: float | None = None, far: float | None = None) -> ClipShot:  # fmt: skip
    """The shifted-sensor rig whose parallax is ``mapping``'s on ``shot``: the truth of a retargeted shot.

    :func:`~vergence.video.convert_clip` maps a shot's nearness ``q`` to the output parallax
    ``P = x_r - x_l = psi(-q)`` with one linear psi (:attr:`ShotConversion.mapping`). ``q`` is affine
    in ``1/z``, so ``P`` is the parallax of a rig with another baseline and convergence distance whose
    left camera is the shot's left camera (the view that ``origin="left"`` keeps).

    Parameters
    ----------
    shot : ClipShot
        The shot as rendered (scene, travel; for ``kind="disparity"`` also its baseline and convergence).
    mapping : vergence.viewing.LinearMapping
        The shot's psi, from input parallax ``-q`` to ``P`` in px of the views.
    focal_px : float
        Focal length of the shot's cameras in px of the views
        (``builtin_scene(shot.scene, width=W, height=H).camera.build().focal_px``).
    kind : {"inverse", "disparity", "metric"}
        What ``q`` is (:data:`vergence.io.DEPTH_KINDS`): the RGBD clip's normalised inverse depth
        ``(1/z - 1/far) / (1/near - 1/far)``, the stereo clip's disparity ``x_l - x_r`` in px, or ``1/z``.
    near, far : float, optional
        The shot's depth range (m) of the RGBD clip's normalisation (``near`` and ``far`` of the truth
        ``.npz``), ``0 < near < far``; ``kind="inverse"`` only.

    Returns
    -------
    ClipShot
        ``shot`` with the equivalent ``baseline`` ``b'`` (m) and ``convergence`` ``H'`` (m).

    Raises
    ------
    TypeError
        ``shot`` not a ClipShot, ``mapping`` not a LinearMapping (a blend across a cut or a non-linear
        psi has no equivalent rig).
    ValueError
        Bad ``kind``, ``focal_px``, ``near``/``far`` (missing for ``inverse``, given for another kind),
        or a psi that puts the zero-parallax plane at or beyond infinity (``psi(-beta) <= 0`` below).

    Notes
    -----
    The shot's rig gives ``x_l - x_r = f b (1/z - 1/H)`` (:func:`vergence.rigs.stereo_pair`, S0 §2,
    Eq. (1a) in px); the nearness is ``q = alpha / z + beta`` with ``(alpha, beta)`` = ``(1, 0)``
    (metric), ``(k, -k / far)`` with ``k = 1 / (1/near - 1/far)`` (inverse: MPEG's 8-bit depth,
    Fehn 2004; S1 §IV.C) or ``(f b, -f b / H)`` (disparity). The linear psi of slope ``g`` (Lang et al.
    2010) gives ``P = psi(-q) = psi(-beta) - g alpha / z``, and a shifted-sensor rig ``(b', H')``
    ``P = f b' (1/H' - 1/z)`` (S1 §IV.C, Table I: ``alpha_u t_c (1/Z_c - 1/Z)``). They agree at every
    depth if and only if

        ``b' = g alpha / f``,   ``1 / H' = psi(-beta) / (g alpha)``.

    Examples
    --------
    Nearness 1/z over 1 to 4 m mapped onto +-4 px, f = 100 px: ``g = 8 / 0.75``, ``b' = g / f``,
    ``1/H' = psi(0) / g = 0.625``; the rig gives ``f b' (0.625 - 1) = -4`` px at 1 m and ``+4`` at 4 m.

    >>> from vergence.viewing import LinearMapping
    >>> shot = ClipShot(scene="tabletop", baseline=0.1, convergence=1.2, travel=0.3)
    >>> rig = retargeted_rig(shot, LinearMapping(-1.0, -0.25, -4.0, 4.0), focal_px=100.0, kind="metric")
    >>> round(rig.baseline, 6), round(rig.convergence, 6), rig.scene
    (0.106667, 1.6, 'tabletop')
    """
    from vergence._validate import check_positive
    from vergence.io import DEPTH_KINDS
    from vergence.viewing import LinearMapping

    if not isinstance(shot, ClipShot):
        raise TypeError(f"shot must be a ClipShot; got {type(shot).__name__}")
    if not isinstance(mapping, LinearMapping):
        raise TypeError(f"mapping must be a LinearMapping (one linear psi per shot: convert_clip's without a "
                        f"transition); got {type(mapping).__name__}")  # fmt: skip
    if kind not in DEPTH_KINDS:
        raise ValueError(f"kind must be one of {', '.join(DEPTH_KINDS)}; got {kind!r}")
    f = check_positive("focal_px", focal_px)
    if kind == "inverse":
        if near is None or far is None:
            raise ValueError("kind='inverse' needs near and far (the RGBD clip's normalisation, m)")
        z_near, z_far = check_positive("near", near), check_positive("far", far)
        if not z_near < z_far:
            raise ValueError(f"near must be < far; got near {z_near:g}, far {z_far:g}")
        alpha = 1.0 / (1.0 / z_near - 1.0 / z_far)
        beta = -alpha / z_far
    else:
        if near is not None or far is not None:
            raise ValueError(f"near and far are for kind='inverse' only; got kind={kind!r}")
        alpha, beta = (1.0, 0.0) if kind == "metric" else (f * shot.baseline, -f * shot.baseline / shot.convergence)
    gain_alpha = mapping.gain * alpha  # f b'
    offset = float(mapping(-beta))  # f b' / H'
    if not offset > 0.0:
        raise ValueError(f"mapping puts the zero-parallax plane at or beyond infinity (P = {offset:.4g} px at "
                         "infinite depth): no shifted-sensor rig converges there")  # fmt: skip
    return dataclasses.replace(shot, baseline=gain_alpha / f, convergence=gain_alpha / offset)


@dataclass(frozen=True, slots=True, eq=False)  # holds arrays: identity equality
class RetargetedViews:
    """What :func:`render_retargeted` rendered: a shot through the retargeted rig.

    Attributes
    ----------
    left, right : (n, H, W, 3) float32
        Tone-mapped views in [0, 1]; ``left`` is the clip's left view before encoding.
    parallax_px : (n, H, W) float32
        ``P = x_r - x_l`` of each left pixel, px (``-``:func:`vergence.render.screen_disparity`).
    visible : (n, H, W) bool
        Right-view pixels whose point the left view sees: not disoccluded, not beside the left view's
        border (its depth at the match brackets theirs within :data:`VISIBLE_RTOL`).
    """

    left: np.ndarray
    right: np.ndarray
    parallax_px: np.ndarray
    visible: np.ndarray


def render_retargeted(shot: ClipShot, rig: ClipShot, *, frames_per_shot: int, width: int,
                      height: int) -> RetargetedViews:  # fmt: skip
    """Render ``shot`` of the test clips with ``rig``'s baseline and convergence, its left camera the shot's.

    With ``rig`` from :func:`retargeted_rig`, ``right`` is the truth of the right view of
    :func:`~vergence.video.convert_clip` with ``origin="left"``.

    Parameters
    ----------
    shot : ClipShot
        The shot as :func:`make_test_clips` rendered it.
    rig : ClipShot
        The same scene and travel, another ``baseline`` and ``convergence`` (m).
    frames_per_shot, width, height : int
        As given to :func:`make_test_clips` (the camera path depends on them).

    Returns
    -------
    RetargetedViews

    Raises
    ------
    TypeError
        ``shot`` or ``rig`` not a ClipShot.
    ValueError
        ``rig`` of another scene or travel, ``frames_per_shot`` below 2, and the rig's lengths outside
        :data:`vergence.viewing.LENGTH_RANGE` (:func:`vergence.rigs.stereo_pair`).

    Notes
    -----
    The left camera is :func:`vergence.rigs.stereo_pair`'s for ``shot``; the right one is the right
    camera of ``stereo_pair(middle, rig.baseline, rig.convergence)`` where ``middle`` is the left camera
    moved ``b'/2`` along its right axis with principal point ``cx + f b' / (2 H')`` (S0 §2): the rig's
    left camera is then the shot's.
    """
    for name, value in (("shot", shot), ("rig", rig)):
        if not isinstance(value, ClipShot):
            raise TypeError(f"{name} must be a ClipShot; got {type(value).__name__}")
    if (rig.scene, rig.travel) != (shot.scene, shot.travel):
        raise ValueError(f"rig must have the shot's scene and travel ({shot.scene!r}, {shot.travel:g} m); got "
                         f"({rig.scene!r}, {rig.travel:g} m)")  # fmt: skip
    if isinstance(frames_per_shot, bool) or not isinstance(frames_per_shot, int) or frames_per_shot < 2:
        raise ValueError(f"frames_per_shot must be an integer >= 2; got {frames_per_shot!r}")
    r = _render_shot(shot, frames_per_shot, width, height, retarget=rig)
    visible = _seen_by_left(np.stack(r.depths), np.stack(r.right_depths), r.focal_px, rig.baseline, rig.convergence)
    return RetargetedViews(left=np.stack(r.lefts).astype(np.float32), right=np.stack(r.rights).astype(np.float32),
                           parallax_px=-np.stack(r.disparities), visible=visible)  # fmt: skip
