"""``vergence rectify``'s work: Fusiello-Trucco-Verri rectification of a calibrated pair (Fusiello et al.
2000; S2 §3.2).

Writes ``out/left.png``, ``out/right.png``, their validity masks ``out/left_valid.png`` and
``out/right_valid.png`` (255 where the rectified pixel comes from inside the original image, 0 in the
black borders; ``vergence match --mask`` takes the left one) and ``out/rectification.json`` (rectified
cameras, homographies, baseline, focal length, doffs and, with ``check``, the measured row alignment).
All five files or none: they are written into a hidden folder beside ``out`` and moved in at the end.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from vergence.commands._naming import literal, naming_both
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.depth import Rectification, RowAlignment, measure_row_alignment, rectify_pair
from vergence.io import atomic_folder, cameras_for_images, read_cameras, read_image, write_image, write_json
from vergence.io.atomic import check_output_path

__all__ = ["OUTPUTS", "RECTIFY", "RectifyReport", "rectify"]

#: The files written in ``out``, rectification.json last.
OUTPUTS = ("left.png", "right.png", "left_valid.png", "right_valid.png", "rectification.json")


@dataclass(frozen=True, slots=True)
class RectifyReport:
    """The rectification of a pair, the images' names, what the camera reader assumed (``notes``), the
    measured row alignment (with ``check``) and the folder the files were written to."""

    rectification: Rectification
    left: str
    right: str
    notes: tuple[str, ...]
    row_alignment: RowAlignment | None
    out: Path

    def to_dict(self) -> dict[str, object]:
        """What ``rectification.json`` holds."""
        data: dict[str, object] = {"left": self.left, "right": self.right, **self.rectification.to_dict()}
        if self.notes:
            data["notes"] = list(self.notes)
        if self.row_alignment is not None:
            data["row_alignment"] = self.row_alignment.to_dict()
        return data


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
    for parameter, path, img in images:
        found = _calibrated_size(path, cameras)
        if found is None:
            continue
        sibling, (w, h) = found
        if (w, h) != (img.shape[1], img.shape[0]):
            raise ParameterError(
                "{" + parameter + "} " + literal(path.name) + f" is {img.shape[1]}x{img.shape[0]} px, but its camera "
                "in " + literal(cameras.name) + f" belongs to the {w}x{h} image " + literal(sibling)
                + ": rectify the images at the size they were calibrated at"
            )


def rectify(*, left: Path, right: Path, cameras: Path, out: Path, image_list: Path | None = None,
            common_principal_point: bool = False, check: bool = False,
            progress: Callable[[float, str], None] | None = None, note: Callable[[str], None] | None = None,
            before_commit: Callable[[], None] | None = None) -> RectifyReport:  # fmt: skip
    """Rectify ``left`` and ``right`` with their cameras in ``cameras`` (each found by its image's file
    name) and write :data:`OUTPUTS` into the folder ``out``, all or none; see
    :func:`vergence.depth.rectify_pair` and :func:`vergence.io.cameras_for_images`.

    Hooks: ``progress(0, "rectifying")`` as the work starts and ``progress(1, ...)`` before the files
    are written; ``note(line)`` for each assumption of the camera reader (a Bundler set without its
    list.txt paired with the folder's images), as it is made (the notes are in the result too);
    ``before_commit()`` once every file is written, before any appears (what it raises commits nothing).

    Raises
    ------
    ParameterError
        An image, a camera file or an option the rectification refuses, naming its parameter.
    OSError
        An input that cannot be read, an output folder that cannot be written.
    """
    left, right, cameras, out = map(Path, (left, right, cameras, out))
    image_list = None if image_list is None else Path(image_list)
    for name in OUTPUTS:
        check_output_path(out / name, left, right, cameras)
    if progress is not None:
        progress(0.0, "rectifying")
    a, b = read_image(left), read_image(right)
    _check_sizes([("left", left, a), ("right", right, b)], cameras)
    try:
        (cam_l, dist_l), (cam_r, dist_r) = cameras_for_images(
            cameras, [(left, (a.shape[1], a.shape[0])), (right, (b.shape[1], b.shape[0]))], image_list=image_list)
    except ValueError as exc:  # the library names its argument; here it is a parameter
        raise ParameterError(literal(exc).replace("pass image_list", "pass {image_list}")
                             .replace("image_list applies", "{image_list} applies")) from exc
    # What the reader assumed (a Bundler set without list.txt paired with the folder's images)
    notes = tuple(read_cameras(cameras, image_size=(a.shape[1], a.shape[0]), image_list=image_list).notes)
    if note is not None:
        for line in notes:
            note(line)
    with naming(left_image="left", right_image="right"), naming_both("left_image and right_image", "left", "right"):
        pair = rectify_pair(a, b, cam_l, cam_r, left_distortion=dist_l, right_distortion=dist_r,
                            common_principal_point=common_principal_point)
    alignment = measure_row_alignment(pair.left, pair.right) if check else None
    report = RectifyReport(pair.rectification, left.name, right.name, notes, alignment, out)
    if progress is not None:
        progress(1.0, "rectified")
    images = (pair.left, pair.right, pair.left_valid.astype(np.float32), pair.right_valid.astype(np.float32))
    with atomic_folder(out) as tmp:  # the five files or none
        for name, image in zip(OUTPUTS, images):
            write_image(tmp / name, image)
        write_json(tmp / OUTPUTS[-1], report.to_dict())
        if before_commit is not None:
            before_commit()
    return report


RECTIFY = Command(
    name="rectify",
    summary="Rectify LEFT and RIGHT with their calibrated cameras: row-aligned images, cameras, homographies.",
    parameters=(
        Parameter("left", "file", "Left image; its file name names its camera in the camera file.", option=""),
        Parameter("right", "file", "Right image (its camera must lie to the right of the left one).", option=""),
        Parameter("cameras", "file", "Camera file: *_par.txt (Middlebury), bundle.out, COLMAP cameras.txt/images.txt "
                  "or their folder, *.json (vergence)."),
        Parameter("out", "output", "Output folder (created if missing): left.png, right.png, left_valid.png, "
                  "right_valid.png (255 = image, 0 = border), rectification.json."),
        Parameter("image_list", "file", "Bundler list.txt naming the images of bundle.out (default: list.txt beside "
                  "it).", None, web=False),  # a text side file: no upload or data id stands for one
        Parameter("common_principal_point", "flag", "Give both rectified cameras one K (doffs = 0; wider outputs).",
                  False),
        Parameter("check", "flag", "Measure the row alignment of SIFT matches (median |dy|).", False),
    ),
    work=rectify,
    hooks=("progress", "note", "before_commit"),
)
