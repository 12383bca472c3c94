"""``vergence rectify``: Fusiello-Trucco-Verri rectification of a calibrated pair (Fusiello et al. 2000; S2 §3.2).

Writes ``DIR/left.png``, ``DIR/right.png``, their validity masks ``DIR/left_valid.png`` and
``DIR/right_valid.png`` (255 where the rectified pixel comes from inside the original image, 0 in the
black borders; ``vergence match --mask`` takes the left one) and ``DIR/rectification.json`` (rectified
cameras, homographies, baseline, focal length, doffs and, with ``--check``, the measured row alignment).
All five files or none: they are written into a hidden folder beside DIR and moved in at the end.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from PIL import Image

from vergence.cli import raise_if_interrupted
from vergence.cli._app import app, check_output_path, console, err_console, options_named, print_json
from vergence.depth import measure_row_alignment, rectify_pair
from vergence.io import atomic_folder, cameras_for_images, read_cameras, read_image, write_image, write_json

__all__ = ["rectify"]

_OUTPUTS = ("left.png", "right.png", "left_valid.png", "right_valid.png", "rectification.json")


def _calibrated_size(image: Path, cameras: Path) -> tuple[Path, tuple[int, int]] | None:
    """The image of ``image``'s name beside the camera file, when it is another file, and its (width, height).

    Middlebury ``*_par.txt`` and Bundler ``bundle.out`` store no image size: their ``K`` holds for the
    images they name, which sit beside them. Another image of that name and a different size would
    be rectified with a ``K`` that is not its own (garbage out).
    """
    folder = cameras if cameras.is_dir() else cameras.parent
    sibling = folder / image.name
    try:
        if not sibling.is_file() or sibling.resolve() == image.resolve():
            return None
        with Image.open(sibling) as im:
            return sibling, (int(im.size[0]), int(im.size[1]))
    except (OSError, ValueError, Image.DecompressionBombError):
        return None  # not an image we can read the header of: nothing to compare with


def _check_sizes(images: list[tuple[str, Path, np.ndarray]], cameras: Path) -> None:
    """Refuse an image whose size differs from the calibrated image of its name beside ``cameras``."""
    for option, path, img in images:
        found = _calibrated_size(path, cameras)
        if found is None:
            continue
        sibling, (w, h) = found
        if (w, h) != (img.shape[1], img.shape[0]):
            raise ValueError(
                f"{option} {path.name} is {img.shape[1]}x{img.shape[0]} px, but its camera in {cameras.name} "
                f"belongs to the {w}x{h} image {sibling}: rectify the images at the size they were calibrated at"
            )


@app.command("rectify")
def rectify(
    left: Path = typer.Argument(..., help="Left image; its file name names its camera in the camera file."),
    right: Path = typer.Argument(..., help="Right image (its camera must lie to the right of the left one)."),
    cameras: Path = typer.Option(
        ..., "--cameras", help="Camera file: *_par.txt (Middlebury), bundle.out, COLMAP cameras.txt/images.txt "
        "or their folder, *.json (vergence)."
    ),
    out: Path = typer.Option(
        ..., "--out", help="Output folder (created if missing): left.png, right.png, left_valid.png, right_valid.png "
        "(255 = image, 0 = border), rectification.json."
    ),
    image_list: Path | None = typer.Option(
        None, "--image-list", help="Bundler list.txt naming the images of bundle.out (default: list.txt beside it)."
    ),
    common_principal_point: bool = typer.Option(
        False, "--common-principal-point", help="Give both rectified cameras one K (doffs = 0; wider outputs)."
    ),
    check: bool = typer.Option(False, "--check", help="Measure the row alignment of SIFT matches (median |dy|)."),
    as_json: bool = typer.Option(False, "--json", help="Print rectification.json on stdout."),
) -> None:
    """Rectify LEFT and RIGHT with their calibrated cameras: row-aligned images, cameras, homographies."""
    for name in _OUTPUTS:
        check_output_path(out / name, left, right, cameras)
    with err_console.status("rectifying", spinner="dots"):
        a, b = read_image(left), read_image(right)
        _check_sizes([("LEFT", left, a), ("RIGHT", right, b)], cameras)
        try:
            (cam_l, dist_l), (cam_r, dist_r) = cameras_for_images(
                cameras, [(left, (a.shape[1], a.shape[0])), (right, (b.shape[1], b.shape[0]))], image_list=image_list)
        except ValueError as exc:  # the library names its argument; here it is an option
            raise ValueError(str(exc).replace("pass image_list", "pass --image-list")
                             .replace("image_list applies", "--image-list applies")) from exc
        # What the reader assumed (a Bundler set without list.txt paired with the folder's images)
        notes = read_cameras(cameras, image_size=(a.shape[1], a.shape[0]), image_list=image_list).notes
        for note in notes:
            err_console.print(f"[yellow]note:[/] {note}", highlight=False, soft_wrap=True)
        with options_named(**{"left_image and right_image": "LEFT and RIGHT"}, left_image="LEFT", right_image="RIGHT"):
            pair = rectify_pair(a, b, cam_l, cam_r, left_distortion=dist_l, right_distortion=dist_r,
                                common_principal_point=common_principal_point)
        data = {"left": left.name, "right": right.name, **pair.rectification.to_dict()}
        if notes:
            data["notes"] = list(notes)
        if check:
            data["row_alignment"] = measure_row_alignment(pair.left, pair.right).to_dict()
    images = (pair.left, pair.right, pair.left_valid.astype(np.float32), pair.right_valid.astype(np.float32))
    with atomic_folder(out) as tmp:  # the five files or none
        for name, image in zip(_OUTPUTS, images):
            write_image(tmp / name, image)
        write_json(tmp / _OUTPUTS[-1], data)
        raise_if_interrupted()  # a Ctrl-C that waited while Numba was inside LLVM: commit nothing
    if as_json:
        print_json(data)
        return
    cam = pair.rectification.left_camera
    console.print(f"rectified {left.name} + {right.name}: {cam.width}x{cam.height}, baseline "
                  f"{pair.rectification.baseline:.6g}, f = {pair.rectification.focal_px:.6g} px, "
                  f"doffs = {pair.rectification.doffs_px:.3f} px -> {out}")
    if check:
        r = data["row_alignment"]
        console.print(f"row alignment: median |dy| = {r['median_abs_dy_px']:.3f} px, 90th percentile "
                      f"{r['p90_abs_dy_px']:.3f} px over {r['matches']} SIFT matches")
