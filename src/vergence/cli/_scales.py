"""The ``--*-scale`` options of ``synthesize`` and ``interpolate``: one check for both, in the library
(:mod:`vergence.commands._outputs`); this name stays until ``synthesize`` reads it from there."""

from __future__ import annotations

from vergence.commands._outputs import SCALE_RANGE, check_scale

__all__ = ["SCALE_RANGE", "check_scale"]
