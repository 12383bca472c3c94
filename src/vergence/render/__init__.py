"""Ray tracing into the S3 ray tree (S3 §3.1; Whitted 1980, Schlick 1994), and the ground truth of every other part.

Mitsuba 3 casts the rays (``llvm_ad_rgb`` on the CPU, ``cuda_ad_rgb`` on a GPU, chosen at run
time); the ray tree, the materials and the shading are ours. Importing this package imports Mitsuba
(``import vergence`` alone does not; matplotlib is not imported: figures live in
``vergence.report.preview``). Scene format: ``docs/scenes.md``.

:class:`Tracer` prepares a scene once and renders any number of cameras (:meth:`Tracer.render`) or
arbitrary rays (:meth:`Tracer.trace_rays`) through three swappable stages: ray generation
(:func:`camera_rays`, one generator per camera type in :data:`RAY_GENERATORS`), intersection
(:class:`Intersector`) and shading (:class:`WhittedShader`). :func:`render` and
:func:`render_stereo` are one-call conveniences on top. :func:`trace_curved` (on a Tracer) and
:func:`render_curved` follow a distorted world's straight rays as curves through the real scene
(the Tri-Rig's ground truth, S0 §6; :mod:`vergence.render.curved`).
"""

from vergence.render._mitsuba import select_variant
from vergence.render.builtin import BUILTIN_SCENES, builtin_scene, open_scene
from vergence.render.curved import render_curved, trace_curved
from vergence.render.lenses import MIN_FOV_DEG, FisheyeCamera
from vergence.render.disparity import screen_disparity
from vergence.render.intersect import Hits, Intersector
from vergence.render.limits import MAX_RENDER_BYTES, MAX_RENDER_RAYS, MAX_RENDER_SIDE, RenderCost, render_cost
from vergence.render.rays import RAY_GENERATORS, SUBPIXEL_OFFSET_RANGE, RayBatch, camera_rays, subpixel_rays
from vergence.render.raytree import MAX_DEPTH, Tracer, render, render_stereo
from vergence.render.results import RayTree, RenderResult, RenderSettings, layer_names
from vergence.render.scene import (
    Checker,
    Diffuse,
    Environment,
    Glass,
    IOR_RANGE,
    MAX_RADIANCE,
    MAX_SCENE_EXTENT,
    Mesh,
    Mirror,
    Rectangle,
    Scene,
    SceneCamera,
    Sphere,
    Stereo,
    Texture,
)
from vergence.render.scenefile import load_scene, scene_from_dict
from vergence.render.shader import AO_PATTERNS, WhittedShader
from vergence.render.shading import schlick
from vergence.render.stereo import StereoPreview, stereo_preview
from vergence.render.tonemap import auto_exposure, tonemap

__all__ = [
    "AO_PATTERNS",
    "BUILTIN_SCENES",
    "Checker",
    "Diffuse",
    "Environment",
    "FisheyeCamera",
    "Glass",
    "Hits",
    "IOR_RANGE",
    "Intersector",
    "MAX_DEPTH",
    "MAX_RADIANCE",
    "MAX_RENDER_BYTES",
    "MAX_RENDER_RAYS",
    "MAX_RENDER_SIDE",
    "MAX_SCENE_EXTENT",
    "MIN_FOV_DEG",
    "Mesh",
    "Mirror",
    "RAY_GENERATORS",
    "RayBatch",
    "RayTree",
    "Rectangle",
    "RenderCost",
    "RenderResult",
    "RenderSettings",
    "SUBPIXEL_OFFSET_RANGE",
    "Scene",
    "SceneCamera",
    "Sphere",
    "Stereo",
    "StereoPreview",
    "Texture",
    "Tracer",
    "WhittedShader",
    "auto_exposure",
    "builtin_scene",
    "camera_rays",
    "layer_names",
    "load_scene",
    "open_scene",
    "render",
    "render_cost",
    "render_curved",
    "render_stereo",
    "scene_from_dict",
    "schlick",
    "screen_disparity",
    "select_variant",
    "stereo_preview",
    "subpixel_rays",
    "tonemap",
    "trace_curved",
]
