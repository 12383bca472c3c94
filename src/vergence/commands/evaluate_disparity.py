"""``vergence evaluate-disparity``'s work: Middlebury bad-pixel and RMS figures of a disparity map
(S1 Eq. 9-10; Scharstein & Szeliski 2002)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.depth import RegionScore, read_middlebury_masks
from vergence.depth import evaluate_disparity as evaluate
from vergence.io import read_disparity, read_image, stores_integers

__all__ = ["EVALUATE_DISPARITY", "DisparityEvaluation", "evaluate_disparity"]


@dataclass(frozen=True, slots=True)
class DisparityEvaluation:
    """The scores per region (``nonocc``, ``all``, ``disc``, perhaps ``textureless``) and what they were
    computed from: ``masks`` is the folder of official masks, or None for regions computed from the truth."""

    scores: dict[str, RegionScore]
    estimate: Path
    truth: Path
    masks: Path | None
    threshold: float

    def to_dict(self) -> dict[str, object]:
        return {name: s.to_dict() for name, s in self.scores.items()}


def evaluate_disparity(*, estimate: Path, truth: Path, estimate_scale: float | None = None,
                       truth_scale: float | None = None, masks: Path | None = None, truth_right: Path | None = None,
                       border: int | None = None, image: Path | None = None,
                       threshold: float = 1.0) -> DisparityEvaluation:
    """Score the disparity ``estimate`` against ``truth`` (:func:`vergence.depth.evaluate_disparity`):
    over Middlebury's official ``masks`` (a folder), or over regions computed from the truth (with
    ``truth_right``, ``border`` and ``image``).

    Raises
    ------
    ParameterError
        A value the command or the library refuses, naming its parameter.
    """
    if masks is not None and (truth_right is not None or image is not None or border is not None):
        raise ParameterError("{masks} replaces the computed regions; do not combine it with {truth_right}, {image} "
                             "or {border}")
    with naming(scale="estimate_scale"):
        est = read_disparity(estimate, scale=estimate_scale)
    with naming(scale="truth_scale"):
        gt = read_disparity(truth, scale=truth_scale)
        # truth_scale reads both truths; a float right truth beside an integer left one takes none
        right = (read_disparity(truth_right, scale=truth_scale if stores_integers(truth_right) else None)
                 if truth_right is not None else None)
    official = read_middlebury_masks(masks) if masks is not None else None
    img = read_image(image) if image is not None else None
    with naming(threshold="threshold", image="image", truth_right="truth_right", estimate="estimate", truth="truth",
                mask="masks", border="border"):
        scores = evaluate(est, gt, masks=official, image=img, truth_right=right, threshold=threshold, border=border)
    return DisparityEvaluation(scores, estimate, truth, masks, threshold)


EVALUATE_DISPARITY = Command(
    name="evaluate-disparity",
    summary="Score ESTIMATE against TRUTH: % bad pixels and RMS over nonocc / all / disc (/ textureless).",
    parameters=(
        Parameter("estimate", "file", "Computed disparity (.pfm, .npy, or .png/.pgm with {estimate_scale}).",
                  option=""),
        Parameter("truth", "file", "Ground-truth disparity (.png/.pgm with {truth_scale}, .pfm, .npy).", option=""),
        Parameter("estimate_scale", "number", "PNG/PGM estimate: value / scale.", None),
        Parameter("truth_scale", "number", "PNG/PGM truth: value / scale.", None),
        Parameter("masks", "file", "Folder with Middlebury nonocc.png, all.png, disc.png.", None,
                  web=False),  # a folder: no upload or data id stands for one
        Parameter("truth_right", "file", "Right ground truth for the computed nonocc (Middlebury 2005/2006: disp5.png "
                  "beside disp1.png, with {truth_scale} 2 {border} 0).", None),
        Parameter("border", "integer", "Pixels ignored at each edge by the computed regions (default 10, as "
                  "StereoMatcher).", None),
        Parameter("image", "file", "Left image: adds the computed textureless region.", None),
        Parameter("threshold", "number", "Bad pixel: |error| > threshold (px).", 1.0),
    ),
    work=evaluate_disparity,
)
