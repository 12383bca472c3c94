"""``vergence stereospace view CAMERAS``: a novel view of a calibrated photo collection (S2 §3.1, §5).

``view`` renders the view at a real camera's pose (``--at NAME``, that camera left out of the
sources: the leave-one-out test, with its PSNR against the real photo) or at a pose between two
cameras (``--between A B --position T``, :func:`vergence.camera.interpolate`), by S2's method
(``mls``), ours (``depth``) or the one-plane baseline (``plane``).
"""

from __future__ import annotations

import time
from pathlib import Path

import typer

from vergence.cli import raise_if_interrupted
from vergence.cli._app import check_output_path, console, err_console, options_named
from vergence.cli._spinner import ProgressLines
from vergence.cli._stereospace_group import camera_index, stereospace_app

__all__ = ["stereospace_app"]

#: ``--method`` values: the one-plane baseline, then :data:`vergence.stereospace.NOVEL_VIEW_METHODS`.
VIEW_METHODS = ("depth", "mls", "plane")

@stereospace_app.command("view")
def view(
    cameras: Path = typer.Argument(..., help="Camera file (Bundler bundle.out, COLMAP, Middlebury _par, JSON)."),
    images: Path = typer.Option(..., "--images", help="Folder of the images, named as in the camera file."),
    at: str | None = typer.Option(None, "--at", help="Render at this real camera's pose (its image name, with or "
                                  "without extension); it is left out of the sources (leave-one-out) unless "
                                  "--keep-target, and the view is scored against its photo."),
    between: tuple[str, str] | None = typer.Option(None, "--between", help="Render between cameras A and B "
                                                   "(give --position T)."),
    position: float | None = typer.Option(None, "--position", help="T in [0, 1] with --between: 0 is A, 1 is B "
                                          "(centres linear, rotations slerp)."),
    exclude: list[str] = typer.Option([], "--exclude", help="Leave this camera out of the sources (repeatable)."),
    method: str = typer.Option("depth", "--method", help="depth (ours: per-view depth matched in the collection, "
                               "checked against the other views, + ULR; matches the 4 sources), mls (S2's "
                               "warps) or plane (one-plane baseline)."),
    keep_target: bool = typer.Option(False, "--keep-target", help="With --at: keep the camera among the sources."),
    out: Path = typer.Option(..., "--out", help="Output image (.png, .jpg, .ppm, .pfm, ...), written atomically."),
) -> None:
    """Render the view of CAMERAS at a camera (--at NAME) or between two (--between A B --position T).

    With --at NAME the camera is left out of the sources by default, so the view is the leave-one-out
    test of S2 §5: its PSNR against the real photo is printed over the whole frame (uncovered pixels
    count with their value: black, or the depth method's fill) and over the pixels both this view
    and the plane baseline cover, each beside the baseline's PSNR over the same pixels.
    """
    if method not in VIEW_METHODS:
        raise ValueError(f"--method must be one of {', '.join(VIEW_METHODS)}; got {method!r}")
    if (at is None) == (between is None):
        raise ValueError("give either --at NAME or --between A B --position T (exactly one)")
    if between is not None and position is None:
        raise ValueError("--between needs --position T (T in [0, 1])")
    if at is not None and position is not None:
        raise ValueError("--position goes with --between, not --at")
    if at is None and keep_target:
        raise ValueError("--keep-target goes with --at")
    if position is not None and not 0.0 <= position <= 1.0:  # also refuses NaN
        raise ValueError(f"--position must be in [0, 1]; got {position}")
    if out.is_dir():
        raise ValueError(f"--out {out} is a folder; give a file")
    if not out.parent.is_dir():
        raise ValueError(f"--out {out}: folder {out.parent} does not exist")

    import numpy as np

    from vergence.camera import interpolate
    from vergence.io import read_image, write_image
    from vergence.metrics import psnr
    from vergence.stereospace import camera_roster, load_collection, novel_view, plane_view

    check_output_path(out, cameras)
    with options_named(cameras_path="CAMERAS", images="--images"):
        roster = camera_roster(cameras, images=images)
    kept = tuple(n for n, status in roster.items() if status == "kept")
    for option, given in (("--at", [at] if at is not None else []), ("--between", list(between or ())),
                          ("--exclude", exclude)):  # refused before the slow triangulation
        for n in given:
            camera_index(kept, n, option, roster)
    with options_named(cameras_path="CAMERAS", images="--images"), ProgressLines() as progress:
        collection = load_collection(cameras, images=images, progress=progress)
    for note in collection.warnings:
        err_console.print(f"note: {note}", highlight=False, soft_wrap=True)
    check_output_path(out, *collection.image_paths)
    names = collection.names
    left_out = {names[camera_index(names, n, "--exclude", roster)] for n in exclude}
    if at is not None:
        i = camera_index(names, at, "--at", roster)
        target = collection.cameras[i]
        if not keep_target:
            left_out.add(names[i])
    else:
        a, b = (camera_index(names, n, "--between", roster) for n in between)
        with options_named(s="--position"):
            target = interpolate(collection.cameras[a], collection.cameras[b], position)
    if len(left_out) >= len(names):
        raise ValueError(f"--exclude leaves no source camera (all {len(names)} excluded)")
    start = time.perf_counter()
    cache: dict = {}
    if method == "plane":
        result = plane_view(collection, target, exclude=sorted(left_out), images=cache)
    else:
        result = novel_view(collection, target, method=method, exclude=sorted(left_out), images=cache)
    elapsed = time.perf_counter() - start
    raise_if_interrupted()  # Ctrl-C while Numba compiled: write nothing
    with options_named(path="--out"):
        write_image(out, np.clip(result.image, 0.0, 1.0))
    console.print(f"{method} view of {target.width} x {target.height} from {', '.join(result.sources)} "
                  f"({100 * result.coverage.mean():.1f} % covered) in {elapsed:.2f} s; wrote {out}",
                  highlight=False)  # fmt: skip
    if at is not None:
        photo = np.asarray(read_image(collection.image_paths[i]), dtype=np.float32)
        photo = np.clip(np.repeat(photo[..., None], 3, axis=2) if photo.ndim == 2 else photo, 0.0, 1.0)
        base = result if method == "plane" else plane_view(collection, target, exclude=sorted(left_out), images=cache)
        whole = np.ones(photo.shape[:2], dtype=bool)  # uncovered pixels count with their value (0, or the fill)
        line = f"PSNR against the photo of {names[i]}: {psnr(result.image, photo, mask=whole):.2f} dB over the whole frame"
        if method != "plane":
            line += f" (plane baseline: {psnr(base.image, photo, mask=whole):.2f} dB)"
        mask = result.coverage & base.coverage
        if not mask.any():
            line += "; no pixel covered by both this view and the plane baseline"
        else:
            covered = "its pixels" if method == "plane" else "pixels both this view and the plane baseline cover"
            line += f"; {psnr(result.image, photo, mask=mask):.2f} dB over the {100 * mask.mean():.1f} % of {covered}"
            if method != "plane":
                line += f" (plane: {psnr(base.image, photo, mask=mask):.2f} dB)"
        console.print(line + ("" if keep_target else " [leave-one-out]"), highlight=False, markup=False)


# build and pair live in their own module; importing it registers them on stereospace_app.
from vergence.cli import _stereospace_space  # noqa: E402, F401
