"""The kinds of job the workbench runs (:data:`JOB_KINDS`): each checks its request, then calls the library.

- ``render``: a scene of ``GET /api/data`` (built-in or a scene file, by id) ray-traced by
  :func:`vergence.render.render` at a small size; the beauty image as ``beauty.png`` (tone-mapped
  by :func:`vergence.render.tonemap`) and the layer count.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import TYPE_CHECKING

import pydantic

from vergence.web.jobs import JobContext, JobKind, JobResult, Prepared

if TYPE_CHECKING:
    from vergence.web.data import DataIndex
    from vergence.web.uploads import UploadStore

__all__ = ["JOB_KINDS", "MAX_RENDER_JOB_RAYS", "MAX_RENDER_JOB_SIDE", "JobEnv", "RenderJob"]

#: Largest side of a render job, pixels: previews on the page, not final frames (``vergence render``).
MAX_RENDER_JOB_SIDE = 2048

#: Largest bound on the rays of a render job (:func:`vergence.render.render_cost`): 1e8, about 20 s
#: at the 4.5 million rays per second measured on two cores (vergence.render.limits).
MAX_RENDER_JOB_RAYS = 100_000_000


@dataclass(frozen=True, slots=True)
class JobEnv:
    """What a kind's ``prepare`` may look up: the data folders' entries and the uploads, by id."""

    data: DataIndex
    uploads: UploadStore


class RenderJob(pydantic.BaseModel):
    """Parameters of a ``render`` job."""

    model_config = pydantic.ConfigDict(extra="forbid")

    scene: str = pydantic.Field(description="A scene id of GET /api/data: 'scene:tabletop' or a scene file's id.")
    width: int = pydantic.Field(64, ge=1, le=MAX_RENDER_JOB_SIDE, description="Image width, pixels.")
    height: int = pydantic.Field(48, ge=1, le=MAX_RENDER_JOB_SIDE, description="Image height, pixels.")
    depth: int = pydantic.Field(2, ge=0, description="Maximum specular bounces D: 2^(D+1)-1 layers.")
    samples: int = pydantic.Field(16, ge=1, description="Ambient-occlusion rays per diffuse hit.")


def _prepare_render(params: pydantic.BaseModel, env: JobEnv) -> Prepared:
    from vergence.render import MAX_DEPTH, builtin_scene, open_scene, render, render_cost, tonemap

    if not isinstance(params, RenderJob):
        raise TypeError(f"params must be a RenderJob; got {type(params).__name__}")
    entry = env.data.get(params.scene)
    if entry.kind != "scene":
        raise ValueError(f"scene: {params.scene!r} is a {entry.kind}, not a scene; GET /api/data lists the scenes")
    if params.depth > MAX_DEPTH:
        raise ValueError(f"depth must be at most {MAX_DEPTH} (2^(D+1)-1 layers); got {params.depth}")
    if entry.path is None:
        scene, inputs = builtin_scene(entry.name, width=params.width, height=params.height), (entry.id,)
    else:
        scene = open_scene(entry.path, width=params.width, height=params.height)
        inputs = (entry.id, hashlib.sha256(entry.path.read_bytes()).hexdigest())
    cost = render_cost(params.width, params.height, max_depth=params.depth, samples=params.samples)
    if cost.problem() is not None:
        raise ValueError(f"{params.width}x{params.height} pixels with depth {params.depth}, samples {params.samples} "
                         f"{cost.problem()}")  # fmt: skip
    if cost.rays > MAX_RENDER_JOB_RAYS:
        raise ValueError(f"{params.width}x{params.height} pixels with depth {params.depth}, samples {params.samples} "
                         f"may cast up to {cost.rays:.3g} rays; a render job's limit is {MAX_RENDER_JOB_RAYS:.0e} "
                         "(MAX_RENDER_JOB_RAYS): lower width, height, depth or samples")  # fmt: skip

    def run(ctx: JobContext) -> JobResult:
        from vergence.io import write_image

        result = render(scene, max_depth=params.depth, samples=params.samples, progress=ctx.progress)
        ctx.progress(1.0, "writing beauty.png")
        write_image(ctx.folder / "beauty.png", tonemap(result.beauty))
        return JobResult({"scene": entry.name, "width": result.camera.width, "height": result.camera.height,
                          "layers": result.n_layers, "variant": result.settings.variant}, ("beauty.png",))  # fmt: skip

    return Prepared(inputs, run)


#: Every kind of job, by name (``POST /api/jobs/{name}``).
JOB_KINDS = {
    "render": JobKind("render", "Ray-trace a scene (vergence.render.render): the beauty image and the layer count.",
                      RenderJob, _prepare_render),
}
