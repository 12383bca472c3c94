"""Ray tracing into the S3 ray tree (S3 §3.1, SPEC §5.1–5.2), and the ground truth of every other part.

Mitsuba 3 casts the rays (``llvm_ad_rgb`` on the CPU, ``cuda_ad_rgb`` on a GPU, chosen at run
time); the ray tree, the materials and the shading are ours. Importing this package imports Mitsuba
(``import vergence`` alone does not). Scene format: ``docs/scenes.md``.
"""

from vergence.render._mitsuba import select_variant
from vergence.render.builtin import BUILTIN_SCENES, builtin_scene, open_scene
from vergence.render.lenses import FisheyeCamera
from vergence.render.preview import auto_exposure, contact_sheet, depth_preview, save_render, tonemap
from vergence.render.raytree import MAX_DEPTH, RenderResult, RenderSettings, layer_names, render, render_stereo
from vergence.render.scene import (
    Checker,
    Diffuse,
    Environment,
    Glass,
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
from vergence.render.shading import schlick
from vergence.render.stereo import StereoPreview, stereo_preview

__all__ = [
    "BUILTIN_SCENES",
    "Checker",
    "Diffuse",
    "Environment",
    "FisheyeCamera",
    "Glass",
    "MAX_DEPTH",
    "Mesh",
    "Mirror",
    "Rectangle",
    "RenderResult",
    "RenderSettings",
    "Scene",
    "SceneCamera",
    "Sphere",
    "Stereo",
    "StereoPreview",
    "Texture",
    "auto_exposure",
    "builtin_scene",
    "contact_sheet",
    "depth_preview",
    "layer_names",
    "load_scene",
    "open_scene",
    "render",
    "render_stereo",
    "save_render",
    "scene_from_dict",
    "schlick",
    "select_variant",
    "stereo_preview",
    "tonemap",
]
