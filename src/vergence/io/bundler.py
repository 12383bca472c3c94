"""Bundler v0.3 ``bundle.out`` camera sets (Snavely et al. 2006), read and written in our conventions.

Bundler's camera looks down -z with y up: ``x_cam = R_b X + t_b``, ``p = -x_cam[:2] / x_cam[2]``,
pixel ``f (1 + k1 |p|^2 + k2 |p|^4) p`` with the origin at the image centre and y up. We flip the y
and z camera axes (``R = diag(1, -1, -1) R_b``, same for t) and move the origin to the top-left
pixel: ``x = x_b + (W - 1)/2``, ``y = (H - 1)/2 - y_b`` (Bundler's ``ImageData::LoadKeys``), which
gives our camera frame (x right, y down, z forward) and pixel convention (``docs/conventions.md``).
``(k1, k2)`` act on the same normalised coordinates in both frames, so they are kept as OpenCV
``(k1, k2, 0, 0)``. Cameras that Bundler could not register (f = 0) are ``None`` in the
:class:`~vergence.io.camera_set.CameraSet`. The file stores no image size: it comes from the images
(named by Bundler's ``list.txt``) or from the caller.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vergence.camera import Camera
from vergence.io._camera_files import (
    check_camera_set,
    check_image_size,
    checked_camera,
    checked_image_list,
    format_float,
    parse_count,
    parse_floats,
    read_image_size,
    text_lines,
    write_text,
)
from vergence.io._files import input_path
from vergence.io.camera_set import CameraSet

__all__ = ["read_bundler", "write_bundler"]

# Bundler's y-up, -z-forward camera frame -> ours (x right, y down, z forward); det = +1.
_FLIP_YZ = np.diag([1.0, -1.0, -1.0])
# The writer requires square pixels and a centred principal point to this tolerance (pixels):
# loose enough for values printed with 10+ digits, tight enough to refuse a real offset.
_PIXEL_TOL = 1e-6


# Bundler's RunBundler.sh lists the images with `ls -1 *.jpg` (sorted by name): without a list.txt
# the cameras are paired with these, in that order.
_BUNDLER_IMAGE_SUFFIXES = (".jpg", ".jpeg")


def _folder_images(p: Path, count: int) -> tuple[list[Path], str] | None:
    """The sorted JPEG images of the bundle's folder or its parent, when there are exactly ``count``."""
    for folder in (p.parent, p.parent.parent):
        images = sorted((q for q in folder.iterdir() if q.suffix.lower() in _BUNDLER_IMAGE_SUFFIXES and q.is_file()),
                        key=lambda q: q.name)  # fmt: skip
        if images and len(images) == count:
            note = (f"{p.name} has no list.txt: its {count} cameras were paired with the {count} JPEG images of "
                    f"{folder} in sorted name order ({images[0].name} .. {images[-1].name}), as Bundler lists them; "
                    "give a list.txt if the order differs")  # fmt: skip
            return images, note
    return None


def _bundler_names(p: Path, count: int, image_list: object) -> tuple[list[str], list[Path] | None, tuple[str, ...]]:
    if image_list is None:
        found = [c for c in (p.parent / "list.txt", p.parent.parent / "list.txt") if c.is_file()]
        if not found:
            images = _folder_images(p, count) if count else None
            if images is None:
                return [str(i) for i in range(count)], None, ()
            return [q.name for q in images[0]], images[0], (images[1],)
        image_list = found[0]
    checked = checked_image_list(image_list)
    if isinstance(checked, Path):
        entries = [ln.split()[0] for ln in text_lines(checked) if ln.strip()]
        paths = [checked.parent / e for e in entries]
    else:
        entries = checked
        paths = [p.parent / e for e in entries]
    if len(entries) != count:
        raise ValueError(f"image_list must name one image per camera ({count}); got {len(entries)}")
    return [Path(e).name for e in entries], paths, ()


def read_bundler(
    path: str | os.PathLike[str],
    *,
    image_size: tuple[int, int] | None = None,
    image_list: str | os.PathLike[str] | Sequence[str] | None = None,
) -> CameraSet:
    """Read a Bundler v0.3 ``bundle.out`` into our conventions (see the module notes).

    Parameters
    ----------
    path : str or os.PathLike
        The bundle file.
    image_size : (width, height), optional
        Shared image size. Without it, sizes are read from the images of ``image_list``.
    image_list : path or sequence of str, optional
        Bundler's ``list.txt`` (one image per camera, in order) or the names themselves; by default
        a ``list.txt`` beside the bundle or in its parent folder. Without one, the cameras are
        paired with the JPEG images of the bundle's folder (or else its parent) in sorted name
        order, as Bundler's ``RunBundler.sh`` lists them, when their number matches; the
        returned set's ``notes`` says so. Otherwise cameras are named ``"0"``, ``"1"``, ... and
        ``image_size`` is required.

    Returns
    -------
    CameraSet
        Unregistered cameras (f = 0) are ``None``; distortion rows hold ``(k1, k2, 0, 0)``.

    Raises
    ------
    ValueError
        On a wrong header, a truncated or malformed file, or a missing image size.
    """
    p = input_path(path)
    lines = text_lines(p)
    if not lines or not lines[0].startswith("# Bundle file v0.3"):
        raise ValueError(f"{p}: expected the header '# Bundle file v0.3'; got {lines[0][:40] if lines else ''!r}")
    tokens = " ".join(lines[1:]).split()
    pos = 0

    def take(n: int, what: str) -> list[float]:
        nonlocal pos
        if pos + n > len(tokens):
            raise ValueError(f"{p} is truncated: ran out of numbers while reading {what}")
        vals = parse_floats(tokens[pos:pos + n], p, 0)
        pos += n
        return vals

    cams_read, pts_read = take(2, "the camera and point counts")
    n_cams, n_pts = parse_count(cams_read, "cameras", p), parse_count(pts_read, "points", p)
    names, paths, notes = _bundler_names(p, n_cams, image_list)
    if image_size is not None:
        sizes = [check_image_size(image_size)] * n_cams
    elif paths is not None:
        sizes = [read_image_size(q) for q in paths]
    else:
        raise ValueError(f"image_size is required: {p.name} stores no image sizes and no list.txt was found beside it")
    cams: list[Camera | None] = []
    dist = np.zeros((n_cams, 4))
    for i in range(n_cams):
        f, k1, k2 = take(3, f"camera {i}")
        R_b = np.array(take(9, f"camera {i}")).reshape(3, 3)
        t_b = np.array(take(3, f"camera {i}"))
        if f == 0.0:
            cams.append(None)
            continue
        w, h = sizes[i]
        K = np.array([[f, 0.0, (w - 1) / 2.0], [0.0, f, (h - 1) / 2.0], [0.0, 0.0, 1.0]])
        cams.append(checked_camera(K, _FLIP_YZ @ R_b, _FLIP_YZ @ t_b, (w, h), f"{p}: camera {i}"))
        dist[i, :2] = k1, k2
    pts, cols, obs, pix = np.zeros((n_pts, 3)), np.zeros((n_pts, 3), np.uint8), [], []
    for j in range(n_pts):
        pts[j] = take(3, f"point {j}")
        cols[j] = np.clip(take(3, f"point {j}"), 0, 255)
        (n_views,) = take(1, f"point {j}")
        for _ in range(parse_count(n_views, f"views of point {j}", p)):
            cam_i, key, xb, yb = take(4, f"point {j}")
            if cam_i != int(cam_i) or not 0 <= cam_i < n_cams or cams[int(cam_i)] is None:
                raise ValueError(f"{p}: point {j} is observed by camera {int(cam_i)}, which is not registered")
            w, h = sizes[int(cam_i)]
            obs.append((j, int(cam_i), int(key)))
            pix.append((xb + (w - 1) / 2.0, (h - 1) / 2.0 - yb))
    return CameraSet(names=tuple(names), cameras=tuple(cams), distortion=dist, points=pts, colors=cols,
                     observations=np.array(obs, np.int64).reshape(-1, 3), observation_pixels=np.array(pix).reshape(-1, 2), notes=notes)


def write_bundler(path: str | os.PathLike[str], cameras: CameraSet) -> None:
    """Write a Bundler v0.3 ``bundle.out`` atomically (inverse of :func:`read_bundler`).

    Raises ``ValueError`` unless every registered camera has square pixels, no skew, the principal
    point at the image centre and radial-only distortion (p1 = p2 = 0), as Bundler's model requires.
    """
    check_camera_set(cameras)
    rows = ["# Bundle file v0.3", f"{len(cameras)} {len(cameras.points)}"]
    for i, cam in enumerate(cameras.cameras):
        if cam is None:
            rows += ["0 0 0"] + ["0 0 0"] * 4
            continue
        K = cam.K
        centre = ((cam.width - 1) / 2.0, (cam.height - 1) / 2.0)
        if (abs(K[0, 0] - K[1, 1]) > _PIXEL_TOL or abs(K[0, 1]) > _PIXEL_TOL or abs(K[0, 2] - centre[0]) > _PIXEL_TOL
                or abs(K[1, 2] - centre[1]) > _PIXEL_TOL or np.any(cameras.distortion[i, 2:] != 0)):
            raise ValueError(f"camera {cameras.names[i]!r} does not fit Bundler's model (square pixels, centred "
                             "principal point, radial distortion only)")
        R, t = _FLIP_YZ @ cam.R, _FLIP_YZ @ cam.t
        rows.append(" ".join(format_float(v) for v in (K[0, 0], *cameras.distortion[i, :2])))
        rows += [" ".join(format_float(v) for v in row) for row in R] + [" ".join(format_float(v) for v in t)]
    for j, (pt, col) in enumerate(zip(cameras.points, cameras.colors)):
        sel = np.flatnonzero(cameras.observations[:, 0] == j)
        views = []
        for k in sel:
            _, ci, key = cameras.observations[k]
            cam = cameras.cameras[ci]
            x, y = cameras.observation_pixels[k]
            views += [str(ci), str(key), format_float(x - (cam.width - 1) / 2.0), format_float((cam.height - 1) / 2.0 - y)]
        rows += [" ".join(format_float(v) for v in pt), " ".join(str(int(c)) for c in col), " ".join([str(len(sel)), *views])]
    write_text(path, "\n".join(rows) + "\n")
