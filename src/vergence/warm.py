"""Compile Vergence's Numba kernels ahead of use: ``vergence warm`` and the workbench's start.

A kernel (``cache=True``) is compiled the first time it runs with a given specialisation (dtypes,
dimensions, memory layout, read-only or not) and the machine code lands in Numba's cache
(:mod:`vergence._cache`); every later process loads it in milliseconds. The first run of a command
would otherwise spend most of its time in LLVM (issue 31: the first ``synthesize`` 52 s, the second
4 s). Each group of :data:`WARM_GROUPS` runs the public functions of one command (or workbench page)
on tiny inputs, read through the same readers the command uses, so that it compiles the same
specialisations the command needs; ``tests/test_warm.py`` checks that a real run after
:func:`warm` compiles nothing new.

Specialisations a command meets only with unusual input (a float64 ``.npy`` image given to a
library function directly, say) are not covered: they compile on first use, as before.
"""

from __future__ import annotations

import importlib.util
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

__all__ = ["WARM_GROUPS", "WarmGroup", "kernel_signatures", "warm"]

Progress = Callable[[float, str], None]

# Side of the tiny inputs, pixels: big enough for every window of the pipelines (SSIM's 7x7, the
# registration's 5x5 patches and radius, the matchers' blocks), small enough to run in milliseconds.
_W, _H = 48, 36


def _texture(h: int = _H, w: int = _W, *, seed: int = 0) -> np.ndarray:
    """A textured RGB float32 image in [0, 1]: smooth gradients plus noise (fixed seed)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    base = np.stack([x / w, y / h, 0.5 + 0.25 * np.sin(x / 3.0) * np.cos(y / 4.0)], axis=-1)
    return np.clip(base + 0.2 * rng.random((h, w, 3), dtype=np.float32), 0.0, 1.0).astype(np.float32)


def _step_depth(h: int = _H, w: int = _W) -> np.ndarray:
    """Metric depth (m) of a near square before a far wall: edges that open holes when warped."""
    depth = np.full((h, w), 4.0, dtype=np.float32)
    depth[h // 4: 3 * h // 4, w // 3: 2 * w // 3] = 1.5
    return depth


def _warm_synthesize(folder: Path) -> None:
    """``vergence synthesize`` and page 2: 2D + depth to a pair, N views, every layout."""
    from vergence.display import LAYOUTS, pack, tile_views
    from vergence.io import read_depth, read_image, write_image, write_pfm
    from vergence.synthesis import FILL_METHODS, synthesize_stereo
    from vergence.viewing.geometry import DISPLAY_PRESETS

    write_image(folder / "image.png", _texture())
    write_pfm(folder / "depth.pfm", _step_depth())
    image = read_image(folder / "image.png")
    depth = read_depth(folder / "depth.pfm", kind="metric")
    display = DISPLAY_PRESETS["desktop-24"]
    for fill in FILL_METHODS:
        result = synthesize_stereo(image, depth, kind="metric", display=display, budget_arcmin=30.0, fill=fill)
    for layout in LAYOUTS:
        pack(result.left, result.right, layout=layout)
    views = synthesize_stereo(image, depth, kind="metric", display=display, budget_px=2.0, views=3)
    tile_views(views.views)


def _warm_compare(folder: Path) -> None:
    """``vergence compare`` (and its twin): PSNR, SSIM, registration error, the error image."""
    from vergence.io import read_image, write_image
    from vergence.synthesis import assess_view, error_image

    write_image(folder / "a.png", _texture(seed=1))
    write_image(folder / "b.png", _texture(seed=2))
    a, b = read_image(folder / "a.png"), read_image(folder / "b.png")
    assess_view(a, b)
    error_image(a, b)


def _warm_interpolate(folder: Path) -> None:
    """``vergence interpolate``: the view between two rectified references and their disparities."""
    from vergence.io import read_disparity, read_image, write_image, write_pfm
    from vergence.synthesis import interpolate_view

    disparity = 8.0 / _step_depth()
    write_image(folder / "l.png", _texture(seed=3))
    write_image(folder / "r.png", _texture(seed=4))
    write_pfm(folder / "dl.pfm", disparity)
    write_pfm(folder / "dr.pfm", disparity)
    left, right = read_image(folder / "l.png"), read_image(folder / "r.png")
    dl, dr = read_disparity(folder / "dl.pfm"), read_disparity(folder / "dr.pfm")
    interpolate_view(left, dl, right, dr, 0.5)


def _shifted_pair(h: int = _H, w: int = _W, shift: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """A rectified pair: a textured background seen ``shift`` px apart and a square twice as near."""
    scene = _texture(h, w + 4 * shift, seed=5)
    left = scene[:, 2 * shift: 2 * shift + w].copy()
    right = scene[:, shift: shift + w].copy()
    y0, y1, x0, x1 = h // 4, 3 * h // 4, w // 3, 2 * w // 3
    square = _texture(y1 - y0, x1 - x0, seed=6)
    left[y0:y1, x0:x1] = square
    right[y0:y1, x0 - shift: x1 - shift] = square
    return left, right


def _warm_match(folder: Path) -> None:
    """``vergence match``, ``evaluate-disparity`` and page 2's left + right input: every matcher and
    smoothing, plane filling, the preview and confidence, the Middlebury scores."""
    from vergence.depth import MATCHERS, SMOOTHING_METHODS, compute_disparity, disparity_preview, evaluate_disparity
    from vergence.io import read_disparity, read_image, write_image, write_pfm

    left, right = _shifted_pair()
    write_image(folder / "l.png", left)
    write_image(folder / "r.png", right)
    a, b = read_image(folder / "l.png"), read_image(folder / "r.png")
    for method in MATCHERS:
        for smoothing in SMOOTHING_METHODS:
            result = compute_disparity(a, b, max_disparity=16, method=method, smoothing=smoothing)
        compute_disparity(a, b, max_disparity=16, method=method, planes=True)
    disparity_preview(result.disparity, lo=0.0, hi=16.0, colour_bar=True)
    write_pfm(folder / "d.pfm", result.disparity)
    estimate = read_disparity(folder / "d.pfm")
    evaluate_disparity(estimate, estimate + 0.5, image=a)


def _warm_render(folder: Path) -> None:
    """``vergence render``, the pages' example renders and the demo's: one eye and a stereo pair of the
    built-in scenes at 8x6 pixels, a seeded and a supersampled render, an environment map, the previews,
    and the demo's right eye synthesised from the left render."""
    import dataclasses

    from vergence.display import pack
    from vergence.render import (Environment, auto_exposure, builtin_scene, render, render_stereo, stereo_preview,
                                 tonemap)
    from vergence.report.preview import save_render
    from vergence.synthesis import synthesize_view

    tabletop = builtin_scene("tabletop", width=8, height=6)
    result = render(tabletop, camera=tabletop.camera.build(), max_depth=2, samples=2)
    save_render(result, folder, exposure=auto_exposure(result.beauty))
    render(tabletop, camera=tabletop.camera.build(), samples=1, supersample=2, rng=np.random.default_rng(0))
    glasses = builtin_scene("glasses", width=8, height=6)
    sky = Environment(image=_texture(4, 8), intensity=1.0, rotation_deg=150.0, source="warm-up")
    glasses = dataclasses.replace(glasses, environment=sky)
    baseline, convergence = glasses.stereo.baseline, glasses.stereo.convergence
    pair = render_stereo(glasses, baseline=baseline, convergence=convergence, max_depth=2, samples=2)
    pack(*(tonemap(r.beauty) for r in pair), layout="anaglyph")
    # the demo's DIBR section: the right eye made from the left render's (read-only) image and depth
    preview = stereo_preview(tabletop, samples=1)
    synthesize_view(preview.left, preview.left_result.depth, preview.left_result.camera, preview.right_result.camera)


def _warm_specular(folder: Path) -> None:
    """``vergence specular`` and page 5: the offset table of ``glasses`` (k = 2, 16x12 pixels), the
    solve with a painted weight map, every output, and a re-optimisation (page 5's repaint)."""
    from vergence.render import builtin_scene
    from vergence.report.specular_outputs import write_specular_outputs
    from vergence.rigs import stereo_pair
    from vergence.specular import COST_TERMS, specular_stereo
    from vergence.viewing.geometry import DISPLAY_PRESETS

    scene = builtin_scene("glasses", width=16, height=12)
    left, right = stereo_pair(scene.camera.build(), baseline=scene.stereo.baseline,
                              convergence=scene.stereo.convergence)
    display = DISPLAY_PRESETS["samsung-2233rz"]
    maps = {term: np.ones((7, 12, 16)) for term in COST_TERMS}
    result = specular_stereo(scene, left, right, display, k=2, samples=1, maps=maps)
    write_specular_outputs(result, folder)
    result.reoptimise(alpha=(1.0, 1.0, 1.0, 1.0), maps=maps)


# The stereospace group's rendered collection: views and their size (pixels), the least that still
# triangulates enough points for a camera graph with regions.
_SPACE_VIEWS = 8
_SPACE_SIZE = (96, 72)


def _warm_stereospace(folder: Path) -> None:
    """``vergence stereospace view / build / pair``, page 3 and the demo's section: a rendered collection
    of the tabletop (small views), its novel views by every method, its space, a pair, a pan and a
    zoom, the map, and the novel views from the prepared collection's images."""
    from vergence.metrics import psnr
    from vergence.render import builtin_scene
    from vergence.report.stereospace_map import navigation_map
    from vergence.stereospace import (NOVEL_VIEW_METHODS, PAIR_METHODS, build_space, load_collection, load_space,
                                      novel_view, pan, plane_view, render_collection, start_state, stereo_pair,
                                      write_space, zoom)

    photos = folder / "photos"
    photos.mkdir()
    scene = builtin_scene("tabletop", width=_SPACE_SIZE[0], height=_SPACE_SIZE[1])
    cameras = render_collection(scene, photos, views=_SPACE_VIEWS, samples=1)
    collection = load_collection(cameras, images=photos)
    target, cache = collection.cameras[1], {}
    exclude = [collection.names[1]]
    base = plane_view(collection, target, exclude=exclude, images=cache)
    for method in NOVEL_VIEW_METHODS:
        view = novel_view(collection, target, method=method, exclude=exclude, images=cache)
        psnr(view.image, base.image, mask=view.coverage & base.coverage)
    built = build_space(cameras, images=photos, collection=collection)
    (folder / "space").mkdir()
    write_space(built, folder / "space")
    built = load_space(folder / "space")
    prepared = built.prepared()
    state = start_state(prepared, built.display)[0]
    navigation_map(built, folder / "map.png", state=state)
    for method in PAIR_METHODS:
        stereo_pair(prepared, state, layout="anaglyph", method=method)
    # views from one source: the per-source MLS kernel (2-4 sources sharing their handles take the other)
    stereo_pair(prepared, state, method=lambda p, camera: PAIR_METHODS["mls"](p, camera, sources=1))
    zoom(built.space, pan(built.space, state, 0.01).state, 0.01)
    pan(built.space, state, 10.0)  # far past the region's border: the search for a jump (S2 §4.1)
    # the demo's leave-one-out views from the prepared collection's (read-only) images
    images = dict(enumerate(prepared.images))
    plane_view(prepared.collection, target, exclude=exclude, images=images)
    for method in NOVEL_VIEW_METHODS:
        novel_view(prepared.collection, target, method=method, exclude=exclude, images=images)


def _tiny_shots() -> tuple[dict[str, object], dict[str, object]]:
    """A Quadri-Rig and a Tri-Rig shot of the stadium at 32x18 pixels (docs/shots.md)."""
    camera = {"position": [0.0, 2.2, 0.0], "look_at": [0.0, 1.1, -30.0], "up": [0, 1, 0], "fov_deg": 8.0,
              "width": 32, "height": 18}  # fmt: skip
    quadri = {"rig": "quadri", "scene": "stadium", "display": "tv-55",
              "camera": {**camera, "position": [0.0, 1.8, -20.0], "look_at": [0.0, 1.8, -30.0]},
              "baseline": 0.3, "convergence": 10.0, "setback": 20.0,
              "elements": [{"name": "subject", "point": [0.0, 1.0, -30.0]},
                           {"name": "background", "point": [0.0, 2.5, -64.0]}]}  # fmt: skip
    tri = {"rig": "tri", "scene": "stadium", "display": "tv-55", "camera": camera,
           "constraints": ["z=30,perceived=3,roundness=1", "z=65,perceived=20"], "reference": "round"}
    return quadri, tri


def _warm_rig(folder: Path) -> None:
    """``vergence rig render`` and page 4: a tiny Quadri-Rig and Tri-Rig shot rendered, the director's
    pair synthesised by both IBR weightings (the Tri-Rig's truth by curved rays)."""
    from vergence.rigs import shot_from_dict
    from vergence.rigs.shoot import RIG_WEIGHTS, render_shot

    for data in _tiny_shots():
        shot = shot_from_dict(data)
        shot.plan()
        render_shot(shot, weights=RIG_WEIGHTS["both"], samples=1)


def _warm_video(folder: Path) -> None:
    """``vergence analyze`` and ``convert`` (the video extra): the rendered test clips at 64x36, a
    stereo and a 2D + depth clip analysed and converted (the latter into every layout)."""
    from vergence.display import LAYOUTS
    from vergence.video import MIN_SHOT_FRAMES, analyze_clip, convert_clip, make_test_clips, open_depth_clip, open_stereo
    from vergence.viewing.geometry import DISPLAY_PRESETS

    clips = make_test_clips(folder, frames_per_shot=MIN_SHOT_FRAMES, width=64, height=36)
    display = DISPLAY_PRESETS["tv-55"]
    stereo, rgbd = open_stereo(clips.stereo), open_depth_clip(clips.rgbd, kind="inverse")
    for clip in (stereo, rgbd):
        analyze_clip(clip, display, every=2)
    convert_clip(stereo, folder / "stereo.mp4", display, preset="ultrafast")
    for layout in LAYOUTS:  # each layout packs its frames its own way (the kernels of either kind of clip)
        convert_clip(rgbd, folder / f"rgbd_{layout}.mp4", display, layout=layout, preset="ultrafast")


@dataclass(frozen=True, slots=True)
class WarmGroup:
    """One warm-up group: the kernels of a command (or a workbench page) and how to compile them.

    Attributes
    ----------
    run : callable(folder)
        Calls the command's public functions on tiny inputs, writing scratch files into ``folder``.
    uses : tuple of str
        The commands and workbench pages whose kernels it compiles (documentation, ``--help``).
    extra : str or None
        The optional extra it needs (``pip install 'vergence[EXTRA]'``), None for the core install.
    module : str or None
        The module of that extra whose absence means the group cannot run.
    """

    run: Callable[[Path], None]
    uses: tuple[str, ...]
    extra: str | None = None
    module: str | None = None

    def missing(self) -> str | None:
        """Why the group cannot run here (its extra is not installed), or None."""
        if self.module is None or importlib.util.find_spec(self.module) is not None:
            return None
        return f"needs the {self.extra} extra: pip install 'vergence[{self.extra}]'"


#: The warm-up groups by name, in the order :func:`warm` runs them by default.
WARM_GROUPS: MappingProxyType[str, WarmGroup] = MappingProxyType({
    "compare": WarmGroup(_warm_compare, ("compare", "page 2")),
    "interpolate": WarmGroup(_warm_interpolate, ("interpolate",)),
    "match": WarmGroup(_warm_match, ("match", "evaluate-disparity", "page 2")),
    "render": WarmGroup(_warm_render, ("render", "demo", "pages 2 and 5")),
    "rig": WarmGroup(_warm_rig, ("rig render", "demo", "page 4")),
    "specular": WarmGroup(_warm_specular, ("specular", "demo", "page 5")),
    "stereospace": WarmGroup(_warm_stereospace, ("stereospace", "demo", "page 3")),
    "synthesize": WarmGroup(_warm_synthesize, ("synthesize", "demo", "page 2")),
    "video": WarmGroup(_warm_video, ("analyze", "convert"), extra="video", module="av"),
})


def warm(groups: Iterable[str] | None = None, *, progress: Progress | None = None) -> dict[str, float]:
    """Run warm-up groups: compile the kernels they use, or load them from Numba's cache.

    Numba caches in ``NUMBA_CACHE_DIR`` when it is set before Numba loads (the ``vergence`` command
    sets it: :func:`vergence._cache.numba_cache_dir`), else beside the kernels' sources.

    Parameters
    ----------
    groups : iterable of str, optional
        Names of :data:`WARM_GROUPS`, run in the order given. Default: every group that can run here,
        in the table's order (a group whose extra is not installed, :meth:`WarmGroup.missing`, is
        left out, and absent from the result).
    progress : callable, optional
        ``progress(fraction, group)`` before each group, with the fraction of the groups done, and
        ``progress(1.0, "")`` after the last.

    Returns
    -------
    dict of str to float
        Seconds each group took, by name, in the order run.

    Raises
    ------
    ValueError
        If a name is not in :data:`WARM_GROUPS` (the message lists them) or repeats.
    ImportError
        If a group named in ``groups`` needs an extra that is not installed.

    Examples
    --------
    >>> seconds = warm(["compare"])  # doctest: +SKIP
    >>> sorted(seconds)  # doctest: +SKIP
    ['compare']
    """
    if groups is None:
        names = [name for name, group in WARM_GROUPS.items() if group.missing() is None]
    else:
        names = [groups] if isinstance(groups, str) else list(groups)
        unknown = [g for g in names if g not in WARM_GROUPS]
        if unknown:
            raise ValueError(f"groups must be names of WARM_GROUPS ({', '.join(WARM_GROUPS)}); got {unknown[0]!r}")
        if len(set(names)) != len(names):
            raise ValueError(f"groups must not repeat a name; got {names}")
        for name in names:
            why = WARM_GROUPS[name].missing()
            if why is not None:
                raise ImportError(f"warm-up group {name} {why}")
    seconds: dict[str, float] = {}
    for i, name in enumerate(names):
        if progress is not None:
            progress(i / len(names), name)
        start = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix=f"vergence-warm-{name}-") as folder:
            WARM_GROUPS[name].run(Path(folder))
        seconds[name] = time.perf_counter() - start
    if progress is not None:
        progress(1.0, "")
    return seconds


def kernel_signatures() -> dict[str, frozenset[str]]:
    """The specialisations compiled or loaded so far in this process, per Vergence kernel.

    Returns
    -------
    dict of str to frozenset of str
        ``module.function`` of each Numba dispatcher defined in a loaded ``vergence`` module -> its
        signatures (``str`` of each argument-type tuple). Empty when Numba is not loaded.
    """
    if "numba" not in sys.modules:
        return {}
    from numba.core.dispatcher import Dispatcher

    found: dict[str, frozenset[str]] = {}
    for name, module in list(sys.modules.items()):
        if module is None or not name.startswith("vergence."):
            continue
        for obj in list(vars(module).values()):
            if isinstance(obj, Dispatcher) and obj.py_func.__module__.startswith("vergence."):
                found[f"{obj.py_func.__module__}.{obj.py_func.__qualname__}"] = frozenset(map(str, obj.signatures))
    return found
