"""``vergence compare``'s work: PSNR, SSIM, DSSIM and the registration error of a view against its
reference (S1 Eq. 11-13, §V.B), with an optional error image."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vergence.commands._naming import literal
from vergence.commands._spec import Command, Parameter, ParameterError, naming
from vergence.io import read_image, write_image
from vergence.io.atomic import check_output_path
from vergence.metrics import MAX_REGISTRATION_RADIUS, MIN_CONTRAST
from vergence.synthesis import ViewQuality, assess_view
from vergence.synthesis import error_image as _error_image  # the name of compare's parameter

__all__ = ["COMPARE", "ComparisonReport", "compare"]


@dataclass(frozen=True, slots=True)
class ComparisonReport:
    """The quality figures and the files they were computed from (``error_image``: where the error
    image was written, or None)."""

    quality: ViewQuality
    image: Path
    reference: Path
    mask: Path | None
    error_image: Path | None

    def to_dict(self) -> dict[str, object]:
        return {"image": str(self.image), "reference": str(self.reference),
                "mask": None if self.mask is None else str(self.mask), **self.quality.to_dict()}


def _mask(path: Path) -> np.ndarray:
    """A mask image: grey, True where the value is above one half (255 in an 8-bit mask)."""
    m = read_image(path)
    if m.ndim != 2:
        raise ParameterError("{mask} " + literal(path) + " must be a single-channel (grey) image; got shape "
                             + literal(m.shape))
    return m > 0.5


def compare(*, image: Path, reference: Path, mask: Path | None = None, radius: float = 10.0,
            min_contrast: float = MIN_CONTRAST, error_image: Path | None = None, error_gain: float = 4.0,
            progress: Callable[[float, str], None] | None = None) -> ComparisonReport:
    """The quality of ``image`` against ``reference`` (:func:`vergence.synthesis.assess_view`), where
    the grey ``mask`` is above one half; ``error_gain`` times ``|image - reference|`` written to
    ``error_image`` when given (:func:`vergence.synthesis.error_image`).

    Hooks: ``progress(0, "comparing")`` as the images are read and ``progress(1, "compared")`` once
    the figures are made, before the error image is written.

    Raises
    ------
    ParameterError
        A value the command or the library refuses, naming its parameter.
    """
    if not (math.isfinite(error_gain) and error_gain > 0):
        raise ParameterError("{error_gain} must be a finite number > 0; got " + str(error_gain))
    if not (math.isfinite(radius) and 0 < radius <= MAX_REGISTRATION_RADIUS):
        raise ParameterError("{radius} must be a number in (0, " + f"{MAX_REGISTRATION_RADIUS}] px; got {radius:g}")
    if error_image is not None:
        check_output_path(error_image, image, reference, *([mask] if mask is not None else []))
    if progress is not None:
        progress(0.0, "comparing")
    a, b = read_image(image), read_image(reference)
    m = _mask(mask) if mask is not None else None
    with naming(min_contrast="min_contrast", radius="radius", mask="mask", image="image", reference="reference"):
        quality = assess_view(a, b, mask=m, radius=radius, min_contrast=min_contrast)
    if progress is not None:
        progress(1.0, "compared")
    if error_image is not None:
        write_image(error_image, _error_image(a, b, gain=error_gain))
    return ComparisonReport(quality, image, reference, mask, error_image)


COMPARE = Command(
    name="compare",
    summary="Compare a view with its reference: PSNR, SSIM, DSSIM, registration error (S1 §V.B).",
    parameters=(
        Parameter("image", "file", "The image to assess (e.g. a synthesized view).", option=""),
        Parameter("reference", "file", "The reference (the real view).", option=""),
        Parameter("mask", "file", "Grey mask: compare where it is above one half.", None),
        Parameter("radius", "number", "Registration-error search radius (px).", 10.0),
        Parameter("min_contrast", "number", "Registration error only where the image's 5x5 patch contrast (RMS, "
                  "[0, 1] units) is at least this; 0: every pixel.", MIN_CONTRAST),
        Parameter("error_image", "output", "Write |image - reference| (channel mean) times {error_gain} here.", None),
        Parameter("error_gain", "number", "Gain of the error image.", 4.0),
    ),
    work=compare,
    hooks=("progress",),
)
