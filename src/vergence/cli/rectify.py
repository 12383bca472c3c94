"""``vergence rectify``: Fusiello-Trucco-Verri rectification of a calibrated pair (Fusiello et al. 2000; S2 §3.2).

Writes ``DIR/left.png``, ``DIR/right.png`` and ``DIR/rectification.json`` (rectified cameras,
homographies, baseline, focal length, doffs and, with ``--check``, the measured row alignment):
all three or none.
"""

from __future__ import annotations

from pathlib import Path

import typer

from vergence.cli._app import app, check_output_path, console, err_console, print_json
from vergence.depth import measure_row_alignment, rectify_pair
from vergence.io import atomic_folder, cameras_for_images, read_cameras, read_image, write_image, write_json

__all__ = ["rectify"]


@app.command("rectify")
def rectify(
    left: Path = typer.Argument(..., help="Left image; its file name names its camera in the camera file."),
    right: Path = typer.Argument(..., help="Right image (its camera must lie to the right of the left one)."),
    cameras: Path = typer.Option(
        ..., "--cameras", help="Camera file: *_par.txt (Middlebury), bundle.out, COLMAP cameras.txt/images.txt "
        "or their folder, *.json (vergence)."
    ),
    out: Path = typer.Option(..., "--out", help="Output folder (created if missing)."),
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
    outputs = [out / "left.png", out / "right.png", out / "rectification.json"]
    for o in outputs:
        check_output_path(o, left, right, cameras)
    with err_console.status("rectifying", spinner="dots"):
        a, b = read_image(left), read_image(right)
        try:
            (cam_l, dist_l), (cam_r, dist_r) = cameras_for_images(
                cameras, [(left, (a.shape[1], a.shape[0])), (right, (b.shape[1], b.shape[0]))], image_list=image_list)
        except ValueError as exc:  # the library names its argument; here it is an option
            raise ValueError(str(exc).replace("pass image_list", "pass --image-list")) from exc
        # What the reader assumed (a Bundler set without list.txt paired with the folder's images)
        notes = read_cameras(cameras, image_size=(a.shape[1], a.shape[0]), image_list=image_list).notes
        for note in notes:
            err_console.print(f"[yellow]note:[/] {note}", highlight=False, soft_wrap=True)
        pair = rectify_pair(a, b, cam_l, cam_r, left_distortion=dist_l, right_distortion=dist_r,
                            common_principal_point=common_principal_point)
        data = {"left": left.name, "right": right.name, **pair.rectification.to_dict()}
        if notes:
            data["notes"] = list(notes)
        if check:
            data["row_alignment"] = measure_row_alignment(pair.left, pair.right).to_dict()
    with atomic_folder(out) as tmp:  # the three files or none
        write_image(tmp / outputs[0].name, pair.left)
        write_image(tmp / outputs[1].name, pair.right)
        write_json(tmp / outputs[2].name, data)
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
