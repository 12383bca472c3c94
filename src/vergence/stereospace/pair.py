"""The stereo pair at a point of the stereospace (S2 §3.2, §4): two novel views, rectified together.

A state ``(region (i, j), li, lj)`` of :class:`~vergence.stereospace.StereoSpace` places the first eye
on segment ``i`` of the camera graph and the second on segment ``j``; each eye's camera is the
interpolation of the segment's two cameras (:func:`vergence.camera.interpolate`: centres linear,
rotations slerp, intrinsics linear). The two cameras are rectified together (Fusiello et al. 2000,
:func:`vergence.depth.rectify_cameras`, restated in S2 §3.2) and each novel view is rendered straight
into its rectified camera: the rectified camera has the novel camera's centre, so this is the novel
view resampled through the Fusiello homography, done in one resampling instead of two.

Decisions (S2 leaves them open)
-------------------------------
- The left eye is the one that keeps the rectified image's down axis pointing down the world
  (:func:`~vergence.stereospace.eye_order` against the collection's up,
  :func:`~vergence.stereospace.collection_up`): S2 §3.2 rectifies "with the x axis from left to right
  centre" and §4.2 keeps the view upright while browsing; deciding by the first eye's image x axis
  turned pairs of rolled photos upside down from one state to the next. ``swapped`` says when the
  left eye is the second eye of the state.
- The rectified views have the collection's image size unless told (``size``, ``width``); both
  rectified extents are fitted into it whole, with one scale and one vertical offset so rows stay
  aligned (``framing="fit"``; ``"crop"`` keeps the collection's scale and cuts them:
  :func:`~vergence.stereospace.frame_cameras`). With a display, a horizontal image shift centres
  the pair's disparity range in the comfort zone (:func:`~vergence.stereospace.convergence_shift`).
- Coincident eyes (interocular distance 0, the diagonal of a triangle) cannot be rectified: both
  views are then the one novel view, unrectified (``rectification`` is None).
- S2's novel view takes the :data:`~vergence.stereospace.S2_MAX_SOURCES` cameras nearest (centre
  distance) to the novel camera as its sources (S2 §3.1: "four of its neighbouring cameras").

Speed
-----
:class:`PreparedCollection` does once what does not depend on the pair: the camera graph, every
image decoded into one stack (8-bit photos as bytes, RGB packed one uint32 a pixel), the sparse
points projected into every camera. A view then
costs one parallel MLS evaluation of its sources at the grid nodes (float32, nodes x handles) and
one fused pass over its pixels (maps, penalties, ULR weights, bilinear samples); the handles and
the nodes' angle penalties come from Numba kernels too (``_mls_view_kernels``), and the handles
the sources share are weighed once for all of them. On the shared 2-core development machine an
anaglyph-packed 640 x 480 pair from 4 sources of the prepared collection takes 58-66 CPU-ms (kermit,
wall 34-36 ms) and 52-69 (dino, wall 31-39) at the median of three runs: under issue 27's goal of
70 CPU-ms, by 0.8 to 17.6; a fourth run at load 3.4 gave 77.7 and 66.2 (``benchmarks/stereospace_pair.py``;
the history and what was tried are in docs/stereospace.md). ``PreparedCollection(grid_step=16)`` makes the maps 2.5 times cheaper.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from vergence._validate import check_positive_int
from vergence.camera import Camera, interpolate
from vergence.depth import Rectification, rectify_cameras
from vergence.display import ANAGLYPH_METHODS, LAYOUTS, pack
from vergence.io import read_image
from vergence.stereospace.collection import Collection
from vergence.stereospace.graph import CameraGraph, camera_graph
from vergence.stereospace.orientation import collection_up, eye_order
from vergence.stereospace.quality import DISPARITY_TRIM
from vergence.stereospace.mls_view import S2_GRID_STEP, S2_MAX_SOURCES, render_source_set, source_set, SourceSet
from vergence.stereospace.framing import FRAMINGS, ConvergenceShift, convergence_shift, frame_cameras
from vergence.stereospace.space import StereoSpace, StereoState
from vergence.viewing import ComfortZone, Display, check_display

__all__ = ["MAX_VIEW_SIDE", "PAIR_METHODS", "PreparedCollection", "StereoPairResult", "pair_cameras", "space_from_graph",
           "stereo_pair"]

ViewMethod = Callable[["PreparedCollection", Camera], np.ndarray]

MAX_VIEW_SIDE = 4096
"""Largest width or height of a pair's views, pixels (:func:`stereo_pair`'s ``size``)."""


def space_from_graph(collection: Collection, graph: CameraGraph) -> tuple[StereoSpace, np.ndarray]:
    """The StereoSpace of a camera graph and the camera index pair of each of its segments.

    Segment ``k`` joins the centres of cameras ``pairs[k, 0]`` and ``pairs[k, 1]``, one per graph
    edge in the graph's order (``graph.edges``, ``a < b``): ``c(k, 0)`` is camera ``pairs[k, 0]``.

    Returns
    -------
    (StereoSpace, (m, 2) int64)
    """
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    if not isinstance(graph, CameraGraph):
        raise TypeError(f"graph must be a CameraGraph; got {type(graph).__name__}")
    if graph.n_nodes != len(collection):
        raise ValueError(f"graph must have one node per camera of collection ({len(collection)}); got {graph.n_nodes}")
    pairs = np.array(graph.edges, dtype=np.int64).reshape(-1, 2)
    centers = collection.centers
    space = StereoSpace(np.stack([centers[pairs[:, 0]], centers[pairs[:, 1]]], axis=1))
    pairs.flags.writeable = False
    return space, pairs


def _segment_cameras(space: StereoSpace, collection: Collection) -> np.ndarray:
    """Each segment end matched to the camera whose centre it is (within the space's tolerance)."""
    centers = collection.centers
    ends = space.segments.reshape(-1, 3)
    dist = np.linalg.norm(ends[:, None] - centers[None], axis=2)
    nearest = dist.argmin(axis=1)
    if (dist[np.arange(len(ends)), nearest] > space.tolerance).any():
        raise ValueError("space must have its segments between camera centres of collection (see space_from_graph)")
    return nearest.reshape(-1, 2)


def pair_cameras(space: StereoSpace, collection: Collection, state: StereoState, *,
                 segment_cameras: object = None) -> tuple[Camera, Camera]:
    """The first and second eye's cameras of a state: segment ``i`` at ``li``, segment ``j`` at ``lj``.

    ``interpolate(a, b, l)`` of the segment's cameras (S2 §8: centres linear, rotations slerp,
    intrinsics linear); at ``l = 0`` and ``l = 1`` these are the collection's cameras themselves.
    ``segment_cameras`` is the second value of :func:`space_from_graph`; by default each segment end
    is matched to the camera at that centre.

    Raises
    ------
    ValueError
        A region that does not exist, parameters outside [0, 1] (or ``li > lj`` on a triangle), a
        segment end that is no camera's centre.
    """
    if not isinstance(space, StereoSpace):
        raise TypeError(f"space must be a StereoSpace; got {type(space).__name__}")
    if not isinstance(collection, Collection):
        raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
    if segment_cameras is None:
        pairs = _segment_cameras(space, collection)
    else:
        pairs = np.asarray(segment_cameras)
        if pairs.shape != (len(space.segments), 2) or not np.issubdtype(pairs.dtype, np.integer):
            raise ValueError(f"segment_cameras must be ({len(space.segments)}, 2) integers; got {pairs.shape}")
        if pairs.min() < 0 or pairs.max() >= len(collection):
            raise ValueError(f"segment_cameras must index the {len(collection)} cameras of collection")
    state = space.check_state(state)
    (i, j), cams = state.region, collection.cameras
    return (interpolate(cams[pairs[i, 0]], cams[pairs[i, 1]], state.li),
            interpolate(cams[pairs[j, 0]], cams[pairs[j, 1]], state.lj))


def _colour_images(images: list[np.ndarray]) -> list[np.ndarray]:
    """``(H, W, C)`` float32 images of one channel count: grey ones repeated to 3 channels when
    the collection mixes grey and colour."""
    hwc = [img[..., None] if img.ndim == 2 else img for img in images]
    if len({img.shape[2] for img in hwc}) > 1:
        hwc = [np.repeat(img, 3, axis=2) if img.shape[2] == 1 else img for img in hwc]
    return [np.ascontiguousarray(img, dtype=np.float32) for img in hwc]


def _decoded(collection: Collection, k: int) -> np.ndarray:
    """The image of camera ``k`` decoded (float32), checked against its camera's size."""
    path, cam = collection.image_paths[k], collection.cameras[k]
    img = read_image(path)
    if img.shape[:2] != (cam.height, cam.width):
        raise ValueError(f"image {path.name} is {img.shape[1]} x {img.shape[0]}; its camera is "
                         f"{cam.width} x {cam.height}")  # fmt: skip
    return img


class PreparedCollection:
    """A collection made ready for fast stereo pairs (done once, then reused for every pair).

    Holds the camera graph, its StereoSpace and segment cameras, the camera centres and what S2's
    novel view needs of every camera as a source, whatever the target: its image decoded
    (decoding a 640 x 480 JPEG costs several milliseconds a view) in one stack, as bytes when the
    photos are 8-bit, and the sparse points projected into it with the mask of those in front of it
    and on its image.

    Parameters
    ----------
    collection : Collection
    graph : CameraGraph, optional
        Default :func:`~vergence.stereospace.camera_graph` of the collection.
    grid_step : int
        Grid spacing of the MLS maps of the pair's views, pixels (:func:`~vergence.stereospace.s2_view`'s
        ``grid_step``; its default, 10, gives the pairs of the bare collection). The cost of the maps
        is nodes x handles: step 16 takes 0.40 of the default's nodes (640 x 480); ``benchmarks/stereospace_pair.py``
        prints how much the views then move (mean absolute difference, colours in [0, 1]).
    """

    __slots__ = ("_sources", "centers", "collection", "graph", "grid_step", "segment_cameras", "space", "up")

    def __init__(self, collection: Collection, *, graph: CameraGraph | None = None,
                 grid_step: int = S2_GRID_STEP) -> None:  # fmt: skip
        if not isinstance(collection, Collection):
            raise TypeError(f"collection must be a Collection; got {type(collection).__name__}")
        self.grid_step = check_positive_int("grid_step", grid_step)
        self.collection = collection
        self.graph = camera_graph(collection) if graph is None else graph
        self.space, self.segment_cameras = space_from_graph(collection, self.graph)
        self.centers = collection.centers
        self.up = collection_up(collection.cameras)
        images = _colour_images([_decoded(collection, k) for k in range(len(collection))])
        self._sources = source_set(collection.cameras, images, collection.points)
        images.clear()
        self._sources.images.flags.writeable = False

    def image(self, k: int) -> np.ndarray:
        """The decoded float32 image of camera ``k``, ``(H, W)`` or ``(H, W, C)``, read-only.

        8-bit photos are kept as bytes (a quarter of the memory; a third for RGB, packed one uint32 a
        pixel): the float32 image is made again on each call, equal to the decoded one bit for bit.
        """
        img = self._sources.image(k)
        if img.flags.writeable:
            img.flags.writeable = False
        return img[..., 0] if img.shape[2] == 1 else img

    @property
    def images(self) -> tuple[np.ndarray, ...]:
        """Every camera's decoded float32 image (:meth:`image`), in the collection's order."""
        return tuple(self.image(k) for k in range(len(self.collection)))

    def view_sources(self, ids: Sequence[int]) -> tuple[SourceSet, np.ndarray]:
        """The sources of S2's views and the positions in it of the cameras ``ids``."""
        return self._sources, np.asarray(ids, dtype=np.int64)


class _Unprepared:
    """The same interface as :class:`PreparedCollection` without the cache: the images a view
    needs decoded and the points projected for that view only."""

    def __init__(self, collection: Collection) -> None:
        self.collection = collection
        self.grid_step = S2_GRID_STEP
        self.graph = camera_graph(collection)
        self.space, self.segment_cameras = space_from_graph(collection, self.graph)
        self.centers = collection.centers
        self.up = collection_up(collection.cameras)

    def image(self, k: int) -> np.ndarray:
        return _decoded(self.collection, k)

    def view_sources(self, ids: Sequence[int]) -> tuple[SourceSet, np.ndarray]:
        cams = [self.collection.cameras[k] for k in ids]
        images = _colour_images([self.image(k) for k in ids])
        return source_set(cams, images, self.collection.points), np.arange(len(ids), dtype=np.int64)


def _mls_view(prepared: PreparedCollection, target: Camera, *, sources: int = S2_MAX_SOURCES) -> np.ndarray:
    """S2's novel view (:func:`~vergence.stereospace.s2_view`, its defaults) from the ``sources``
    nearest cameras."""
    distance = np.linalg.norm(prepared.centers - target.center, axis=1)
    nearest = np.lexsort((np.arange(len(distance)), distance))[:sources]
    source_set, ids = prepared.view_sources(nearest)
    image = render_source_set(target, source_set, ids, prepared.collection.points, grid_step=prepared.grid_step, alpha=1.0,
                    k=S2_MAX_SOURCES, keep_weights=False)[0]  # fmt: skip
    return image[..., 0] if image.shape[2] == 1 else image


PAIR_METHODS: dict[str, ViewMethod] = {"mls": _mls_view}
"""Novel-view methods of :func:`stereo_pair` by name; ``method`` may also be a callable
``method(prepared, target_camera) -> image`` of the target camera's size (e.g. a depth-based view)."""


@dataclass(frozen=True, slots=True, eq=False)
class StereoPairResult:
    """The stereo pair at a state.

    Attributes
    ----------
    left, right : (H, W[, C]) float32
        The rectified novel views (rows aligned), 0 where no source covers a pixel.
    cameras : (Camera, Camera)
        The novel cameras of the first and second eye (the state's order, unrectified).
    rectified : (Camera, Camera)
        The cameras of ``left`` and ``right``.
    rectification : Rectification or None
        Fusiello's rectification of the (left, right) novel cameras before the framing and the
        shift (its cameras have their own extents); None for coincident eyes.
    swapped : bool
        True when the left view is the second eye's.
    point : (4,) float64
        The stereo point ``s(a, b)`` of the state (S2 Eq. 1).
    packed : ndarray or None
        The pair packed for ``layout`` (:func:`vergence.display.pack`), when one was asked.
    shift : ConvergenceShift or None
        The horizontal image shift applied for the display (None: no display given, or coincident eyes).
    """

    left: np.ndarray
    right: np.ndarray
    cameras: tuple[Camera, Camera]
    rectified: tuple[Camera, Camera]
    rectification: Rectification | None
    swapped: bool
    point: np.ndarray
    packed: np.ndarray | None
    shift: ConvergenceShift | None = None


def _rectified_cameras(first: Camera, second: Camera, tolerance: float, up: np.ndarray):
    """(left, right) rectified cameras of their own extents, the Rectification and whether swapped;
    ``(first, first), None, False`` for coincident eyes."""
    baseline = second.center - first.center
    if np.linalg.norm(baseline) <= tolerance:
        return (first, first), None, False
    swapped = eye_order(first, second, up)
    left, right = (second, first) if swapped else (first, second)
    rect = rectify_cameras(left, right, up=up)
    return (rect.left_camera, rect.right_camera), rect, swapped


def _output_size(first: Camera, width: object, size: object) -> tuple[int, int]:
    """The views' (width, height): ``size``, or ``width`` at the collection's aspect ratio, or its size."""
    full_w, full_h = first.width, first.height
    whole = lambda v: not isinstance(v, bool) and isinstance(v, (int, np.integer))  # noqa: E731
    if width is not None and size is not None:
        raise ValueError("give width or size, not both")
    if width is not None:
        if not whole(width) or not 1 <= width <= full_w:
            raise ValueError(f"width must be a whole number of pixels in [1, {full_w}] (the image width); got {width!r}")
        return int(width), max(1, round(full_h * int(width) / full_w))
    if size is None:
        return full_w, full_h
    if (not isinstance(size, (tuple, list)) or len(size) != 2 or not all(whole(v) for v in size)
            or not all(1 <= v <= MAX_VIEW_SIDE for v in size)):  # fmt: skip
        raise ValueError(f"size must be (width, height), whole numbers of pixels in [1, {MAX_VIEW_SIDE}]; got {size!r}")
    return int(size[0]), int(size[1])


def _packed(left: np.ndarray, right: np.ndarray, layout: str, *, own: bool) -> np.ndarray:
    """:func:`~vergence.display.pack` of the views; ``own``: the built-in method's views, float32 in
    [0, 1] without NaN (ULR weights summing to at most 1 over samples in [0, 1]), which an anaglyph
    layout packs without validating them again (pack's checks read every value of both views twice:
    0.7 CPU-ms of a 640 x 480 pair; the same image). Views with an alpha channel go to pack (which refuses them)."""
    if not (own and layout.startswith("anaglyph") and all(v.ndim == 2 or v.shape[2] == 3 for v in (left, right))):
        return pack(left, right, layout=layout)
    rgb = [np.repeat(v[:, :, None], 3, axis=2) if v.ndim == 2 else v for v in (left, right)]
    method = ANAGLYPH_METHODS[layout.removeprefix("anaglyph").removeprefix("-") or "dubois"]
    return np.ascontiguousarray(method(*rgb), dtype=np.float32)


def _resolve(method: object) -> ViewMethod:
    if callable(method):
        return method  # type: ignore[return-value]
    if isinstance(method, str) and method in PAIR_METHODS:
        return PAIR_METHODS[method]
    raise ValueError(f"method must be one of {', '.join(PAIR_METHODS)} or a callable; got {method!r}")


def stereo_pair(
    prepared: PreparedCollection | Collection,
    state: StereoState,
    *,
    layout: str | None = None,
    method: str | ViewMethod = "mls",
    width: int | None = None,
    size: tuple[int, int] | None = None,
    framing: str = "fit",
    display: Display | None = None,
    zone: ComfortZone | None = None,
    shift: bool = True,
) -> StereoPairResult:
    """The stereo pair of a state: two novel views rectified together, framed, shifted, optionally packed.

    Parameters
    ----------
    prepared : PreparedCollection or Collection
        A prepared collection (fast), or a bare Collection: then the graph is built and the images
        decoded for this pair only (the same pair, slower; the benchmark's baseline).
    state : StereoState
        Region and parameters in ``prepared.space``.
    layout : str, optional
        A key of :data:`vergence.display.LAYOUTS` for ``packed``.
    method : str or callable
        ``"mls"`` (S2 §3.1, :func:`~vergence.stereospace.s2_view`) or ``method(prepared, camera)``.
    width : int, optional
        Width of the views in pixels, at most the collection's image width; the height follows the
        collection's aspect ratio. The rectified cameras image the same extent on fewer pixels
        (their intrinsics scaled as a resize scales them), so a smaller working width costs
        proportionally less (the MLS grid keeps its spacing in pixels: fewer nodes too), e.g. for
        interactive browsing (the workbench's StereoSpace page).
    size : (int, int), optional
        ``(width, height)`` of the views, each in [1, :data:`MAX_VIEW_SIDE`] (instead of ``width``;
        default the collection's image size).
    framing : str
        ``"fit"`` (default: both whole rectified extents fit the frame) or ``"crop"`` (the
        collection's scale, centred, cut at the frame), :func:`~vergence.stereospace.frame_cameras`.
    display : Display, optional
        With a display, the views are shifted horizontally so that the range of the points'
        disparities is centred in ``zone`` on it (:func:`~vergence.stereospace.convergence_shift`,
        its 1st to 99th percentiles, :data:`~vergence.stereospace.DISPARITY_TRIM`); ``shift`` of the
        result says what was done. None: no shift.
    zone : ComfortZone, optional
        The comfort zone of the shift (default ±60 arcmin).
    shift : bool
        With a display: False measures the disparity range on it without shifting (``shift`` of the
        result then has ``applied`` False).

    Raises
    ------
    ValueError
        A region that does not exist, parameters outside [0, 1], an unknown layout, method or
        framing, a width that is not a whole number in [1, image width], a bad size, a pair that
        cannot be rectified (baseline along the viewing direction).
    """
    if layout is not None and (not isinstance(layout, str) or layout not in LAYOUTS):
        raise ValueError(f"layout must be one of {', '.join(LAYOUTS)}; got {layout!r}")
    if framing not in FRAMINGS:
        raise ValueError(f"framing must be one of {', '.join(FRAMINGS)}; got {framing!r}")
    if display is not None:
        check_display(display, resolution=True)
    if not isinstance(shift, bool):
        raise TypeError(f"shift must be a bool; got {type(shift).__name__}")
    if zone is not None and not isinstance(zone, ComfortZone):
        raise TypeError(f"zone must be a ComfortZone; got {type(zone).__name__}")
    render = _resolve(method)
    if isinstance(prepared, Collection):
        prepared = _Unprepared(prepared)  # type: ignore[assignment]
    elif not isinstance(prepared, PreparedCollection):
        raise TypeError(f"prepared must be a PreparedCollection or a Collection; got {type(prepared).__name__}")
    space = prepared.space
    first, second = pair_cameras(space, prepared.collection, state, segment_cameras=prepared.segment_cameras)
    out_size = _output_size(first, width, size)
    (cam_l, cam_r), rect, swapped = _rectified_cameras(first, second, space.tolerance, prepared.up)
    if rect is None:  # coincident eyes: the novel camera itself, framed as the collection's images
        cam_l = cam_r = frame_cameras(first, first, out_size, framing="crop", reference_width=first.width)[0] \
            if out_size != (first.width, first.height) else first  # fmt: skip
        hit = None
    else:
        cam_l, cam_r = frame_cameras(cam_l, cam_r, out_size, framing=framing, reference_width=first.width)
        hit = None
        if display is not None:
            cam_l, cam_r, hit = convergence_shift(cam_l, cam_r, prepared.collection.points, display, zone=zone,
                                                  trim=DISPARITY_TRIM, apply=shift)  # fmt: skip
    left = np.asarray(render(prepared, cam_l), dtype=np.float32)  # type: ignore[arg-type]
    right = left if rect is None else np.asarray(render(prepared, cam_r), dtype=np.float32)  # type: ignore[arg-type]
    for name, view in (("left", left), ("right", right)):
        if view.shape[:2] != (cam_l.height, cam_l.width):
            raise ValueError(f"method returned a {name} view of shape {view.shape}; expected "
                             f"({cam_l.height}, {cam_l.width}[, C])")  # fmt: skip
    packed = None if layout is None else _packed(left, right, layout, own=render is _mls_view)
    point = space.point(state.region[0], state.li, state.region[1], state.lj)
    return StereoPairResult(left=left, right=right, cameras=(first, second), rectified=(cam_l, cam_r),
                            rectification=rect, swapped=swapped, point=point, packed=packed, shift=hit)
