"""What a render will cost, estimated before anything is allocated, and the limits it must stay under.

A render traces ``slots = width x height x views x (1 + k^2 if k > 1)`` ray trees (``k``: the
supersampling factor). Each tree has at most ``N = 2^(D+1) - 1`` nodes, one ray each; the diffuse
hits of a tree, where ambient occlusion casts ``samples`` rays, have no children, so there are at
most as many as leaves, ``2^D``. Hence the bounds

    rays  <= slots x (N + 2^D x samples)
    bytes ~= slots x (RAY_BYTES + N x LAYER_BYTES)

:func:`render_cost` returns both; the renderer refuses a render past :data:`MAX_RENDER_RAYS` or
:data:`MAX_RENDER_BYTES` (or a side past :data:`MAX_RENDER_SIDE`) before casting a ray.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vergence._validate import check_positive_int

__all__ = ["MAX_DEPTH", "MAX_RENDER_BYTES", "MAX_RENDER_RAYS", "MAX_RENDER_SIDE", "RenderCost", "render_cost"]

#: Largest number of specular bounces D of a ray tree: 6, i.e. 127 layers; beyond that the arrays
#: outgrow memory long before they help (and ``2^(D+1)`` of a huge D never finishes computing).
MAX_DEPTH = 6

#: Largest estimated memory of one render call, bytes (8 GiB): a stereo pair at 1920 x 1080 with
#: D = 2 is estimated at 5.2 GB (a single 3840 x 2160 view at 10.4 GB is refused); 8 GiB stays
#: inside the 12 GB a fuzzing run (issue 9) and a 16 GB machine give a process, so an oversized
#: render is refused instead of killed by the kernel. The estimate is conservative: measured
#: peaks were 0.6-0.8 of it (800 x 600, D = 0..4, supersample 1 and 3).
MAX_RENDER_BYTES = 8 * 2**30

#: Largest bound on the rays of one render call (1e9): about four minutes at the 4.5 million rays
#: per second measured on two CPU cores (800 x 600 tabletop, D = 2, 16 AO samples).
MAX_RENDER_RAYS = 1_000_000_000

#: Largest image side, pixels (32768 = 8 x the width of a 4K frame). The previews are PNG files;
#: OpenCV's PNG writer fails past 10^6 px per side and the image-size arguments reach Numba kernels
#: that take 64-bit integers only.
MAX_RENDER_SIDE = 32_768

#: Bytes per ray tree besides its layers: rays, hits and shading inputs of the wavefront, float64
#: (measured: peak RSS of a D = 0 render is 840-880 B per pixel at 800 x 600, tabletop).
RAY_BYTES = 1000

#: Bytes per ray tree and layer: radiance, position and normal, three float32 each.
LAYER_BYTES = 36


def check_max_depth(max_depth: object) -> int:
    """``max_depth`` as an int, refused unless an integer in [0, MAX_DEPTH]."""
    if isinstance(max_depth, bool) or not isinstance(max_depth, int | np.integer) or not 0 <= max_depth <= MAX_DEPTH:
        raise ValueError(f"max_depth must be an integer in [0, {MAX_DEPTH}]; got {max_depth!r}")
    return int(max_depth)


@dataclass(frozen=True, slots=True)
class RenderCost:
    """The estimated cost of a render (:func:`render_cost`).

    Attributes
    ----------
    trees : int
        Ray trees traced: pixels x views, times ``1 + k^2`` with supersampling ``k > 1``.
    rays : int
        Upper bound on the rays cast: tree rays plus ambient-occlusion rays.
    bytes : int
        Estimated peak memory, bytes.
    """

    trees: int
    rays: int
    bytes: int

    def problem(self) -> str | None:
        """What passes a limit, in words, or None when the render fits."""
        if self.bytes > MAX_RENDER_BYTES:
            return (f"needs an estimated {self.bytes / 2**30:.3g} GiB of memory; the limit is "
                    f"{MAX_RENDER_BYTES / 2**30:g} GiB (MAX_RENDER_BYTES)")  # fmt: skip
        if self.rays > MAX_RENDER_RAYS:
            return f"may cast up to {self.rays:.3g} rays; the limit is {MAX_RENDER_RAYS:.0e} (MAX_RENDER_RAYS)"
        return None


def render_cost(width: int, height: int, *, max_depth: int, samples: int, supersample: int = 1,
                views: int = 1) -> RenderCost:  # fmt: skip
    """Estimate the rays and memory of a render (module notes), without allocating anything.

    Parameters
    ----------
    width, height : int
        Image size, pixels.
    max_depth : int
        Specular bounces D (N = 2^(D+1) - 1 layers).
    samples : int
        Ambient-occlusion rays per diffuse hit.
    supersample : int
        k: k x k sub-pixel rays per pixel besides the centre ray when k > 1.
    views : int
        Cameras rendered together (2 for a stereo pair).

    Examples
    --------
    >>> c = render_cost(640, 480, max_depth=2, samples=16)
    >>> c.trees, c.rays
    (307200, 21811200)
    """
    width, height, samples, supersample, views = (check_positive_int(name, value) for name, value in (
        ("width", width), ("height", height), ("samples", samples), ("supersample", supersample), ("views", views)))
    check_max_depth(max_depth)
    n = 2 ** (max_depth + 1) - 1
    trees = int(width) * int(height) * int(views) * (1 + supersample**2 if supersample > 1 else 1)
    return RenderCost(trees=trees, rays=trees * (n + 2**max_depth * samples), bytes=trees * (RAY_BYTES + n * LAYER_BYTES))
