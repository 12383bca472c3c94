"""Test clips with known truth: camera moves through the built-in scenes, rendered left + right + depth.

:func:`make_test_clips` renders two shots with a cut between them (``tabletop``, then ``stadium``),
each a sideways camera move, with the shifted-sensor rig of :func:`vergence.rigs.stereo_pair`, and
writes them as a full side-by-side stereo video and as an iw3-style RGBD video (colour left, 8-bit
inverse depth right, normalised per shot), with the truth of every frame in an ``.npz``: the left view's disparity
``x_left - x_right`` (px, :func:`vergence.render.screen_disparity`) and metric depth, and the
frame where each shot starts. The truth is exact; the videos are H.264 (lossy, ``crf``).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.video.layout import layout_video_name

__all__ = ["CLIP_SHOTS", "ClipShot", "TestClips", "make_test_clips"]


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


def _render_shot(shot: ClipShot, frames: int, width: int, height: int) -> tuple[list, list, list, list]:
    from vergence.render import Tracer, auto_exposure, builtin_scene, screen_disparity, tonemap
    from vergence.rigs import stereo_pair

    scene = builtin_scene(shot.scene, width=width, height=height)
    tracer = Tracer(scene)
    lefts, rights, disparities, depths = [], [], [], []
    exposure = None
    for k in range(frames):
        dx = shot.travel * (k / max(frames - 1, 1) - 0.5)
        move = np.array([dx, 0.0, 0.0])
        cam = dataclasses.replace(scene.camera, position=scene.camera.position + move,
                                  look_at=scene.camera.look_at + move).build()  # fmt: skip
        left_cam, right_cam = stereo_pair(cam, baseline=shot.baseline, convergence=shot.convergence)
        left = tracer.render(left_cam, max_depth=0, samples=4)
        right = tracer.render(right_cam, max_depth=0, samples=4)
        if exposure is None:  # one exposure per shot: no flicker
            exposure = auto_exposure(left.beauty)
        lefts.append(tonemap(left.beauty, exposure=exposure))
        rights.append(tonemap(right.beauty, exposure=exposure))
        disparities.append(screen_disparity(left, right).astype(np.float32))
        depths.append(np.asarray(left.depth, dtype=np.float32))
    return lefts, rights, disparities, depths


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
    disparity = np.stack([d for r in rendered for d in r[2]])
    depth = np.stack([d for r in rendered for d in r[3]])
    # iw3 normalises the inverse depth per frame; here per shot (no flicker within a shot, and the far
    # stadium keeps its levels instead of sharing 8 bits with the tabletop).
    near = np.array([np.nanmin(np.stack(r[3])) for r in rendered], dtype=np.float64)
    far = np.array([np.nanmax(np.stack(r[3])) for r in rendered], dtype=np.float64)
    stereo_path = out / layout_video_name(name, "sbs")
    rgbd_path = out / layout_video_name(name, "rgbd")
    with VideoWriter(stereo_path, fps=24, width=2 * width, height=height, crf=crf) as stereo, \
            VideoWriter(rgbd_path, fps=24, width=2 * width, height=height, crf=crf) as rgbd:  # fmt: skip
        for (lefts, rights, _, depths), z_near, z_far in zip(rendered, near, far):
            for left, right, z in zip(lefts, rights, depths):
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
