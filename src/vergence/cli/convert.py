"""``vergence convert``: retarget a stereo or 2D + depth clip into a display's parallax budget, as video."""

from __future__ import annotations

import time
from pathlib import Path

import typer

from vergence.cli import note_if_interrupted, raise_if_interrupted
from vergence.cli.budget import print_warnings
from vergence.cli._app import SYNTHESIS_BUDGET_ARCMIN, app, check_output_path, console, err_console, options_named, \
    preset_display, print_json  # fmt: skip
from vergence.cli._video import (
    DEPTH_KIND_OPTION,
    DEPTH_SCALE_OPTION,
    FPS_OPTION,
    INPUT_KIND_OPTION,
    LAYOUT_OPTION,
    MAX_DISPARITY_OPTION,
    METHOD_OPTION,
    MIN_DISPARITY_OPTION,
    check_input_kind,
    open_input,
)
from vergence.display import LAYOUTS

__all__ = ["convert"]

_OPTIONS = {"layout": "--format", "budget_arcmin": "--budget-arcmin", "pixel_format": "--pixel-format", "crf": "--crf", "preset": "--preset",
            "origin": "--origin", "threshold": "--static-threshold", "alpha": "--stabilize-alpha",
            "transition": "--transition", "method": "--method", "min_disparity": "--min-disparity",
            "max_disparity": "--max-disparity", "out": "--out",
            "workers": "--workers", "scheduler": "--scheduler", "split_frames": "--split-frames"}  # fmt: skip
_PHASES = {"shots": "finding cuts", "matching": "matching", "converting": "converting"}


def _stamp(path: Path) -> tuple[int, int] | None:
    """The inode and modification time of ``path`` (None if missing): a new output moved into place changes it."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_mtime_ns


@app.command("convert")
def convert(
    input_path: Path = typer.Argument(..., metavar="INPUT", help="A stereo video or image folder (SBS or TB, full or "
                                      "half), or a 2D + depth one (iw3's _RGBD, or colour with --depth)."),
    out: Path = typer.Option(..., "--out", help="Output .mp4/.mkv/.mov (its name gets the layout tag, e.g. "
                             "_LRF_Full_SBS), or a folder to write it into (created when missing); with --images, "
                             "a folder. An existing output is never replaced without --force."),
    display_preset: str = typer.Option(..., "--display", help="Display preset (vergence budget --help lists them)."),
    budget_arcmin: float = typer.Option(SYNTHESIS_BUDGET_ARCMIN, "--budget-arcmin", help="Parallax budget +-A "
                                        "arcmin of vergence on the display, fitted per shot."),
    fmt: str = typer.Option("sbs", "--format", help=f"Output layout: {', '.join(LAYOUTS)}."),
    pixel_format: str | None = typer.Option(None, "--pixel-format", help="yuv420p (every player; default) or "
                                            "yuv444p (default for anaglyphs: no chroma crosstalk)."),
    crf: int = typer.Option(18, "--crf", help="x264 quality: 0 lossless, 18 visually lossless, 51 worst."),
    preset: str = typer.Option("medium", "--preset", help="x264 speed: ultrafast ... veryslow (faster: larger "
                               "files at the same --crf)."),
    images: bool = typer.Option(False, "--images", help="Write PNG frames into a folder instead of a video."),
    depth: Path | None = typer.Option(None, "--depth", help="The depth clip of a colour INPUT (same length and size)."),
    kind: str | None = INPUT_KIND_OPTION,
    layout: str | None = LAYOUT_OPTION,
    depth_kind: str | None = DEPTH_KIND_OPTION,
    depth_scale: float | None = DEPTH_SCALE_OPTION,
    origin: str | None = typer.Option(None, "--origin", help="left: keep the original view as the left one "
                                      "(stereo default); center: both views around it (2D + depth default)."),
    no_stabilize: bool = typer.Option(False, "--no-stabilize", help="Do not filter the disparity in time on "
                                      "static content."),
    static_threshold: float = typer.Option(0.03, "--static-threshold", help="Grey-level change (0-1) below which a "
                                           "pixel is static (stabilisation and flicker measure)."),
    stabilize_alpha: float = typer.Option(0.25, "--stabilize-alpha", help="Weight of the new disparity on static "
                                          "pixels (1 = no filter)."),
    transition: float = typer.Option(0.0, "--transition", help="Frames over which the mapping ramps across a cut "
                                     "(0 = reset at the cut)."),
    method: str | None = METHOD_OPTION,
    min_disparity: int | None = MIN_DISPARITY_OPTION,
    max_disparity: int | None = MAX_DISPARITY_OPTION,
    fps: float | None = FPS_OPTION,
    resume: bool = typer.Option(False, "--resume", help="Reuse the finished shots of an interrupted run (its work "
                                "folder .OUT.parts beside the output)."),
    floating_window: bool = typer.Option(False, "--floating-window", help="Mask, per shot, the frame edge where "
                                         "content comes in front of the screen (black columns at the left edge of "
                                         "the left view, the right edge of the right view); without it such a shot "
                                         "is warned about."),
    force: bool = typer.Option(False, "--force", help="Replace an output file (or an image folder holding files) "
                               "that exists; never an input."),
    workers: int = typer.Option(1, "--workers", help="Render the shots as Dask tasks on a local cluster of N "
                                "processes (N > 1; needs the dask extra of vergence)."),
    as_json: bool = typer.Option(False, "--json", help="Print the conversion as JSON (per shot: the range matched, "
                                 "its search, the disparity planned and measured on the output, positive in front "
                                 "of the screen, the depth order, the flicker, the floating window)."),
    batch: bool = typer.Option(False, "--batch", help="INPUT is a folder: convert each .mp4/.mkv/.mov in it into the "
                               "--out folder (kind and layout guessed per file; one Dask cluster for all)."),
    skip_errors: bool = typer.Option(False, "--skip-errors", help="--batch: a file that fails is reported in one "
                                     "line and skipped (exit code 2 at the end); default: stop at it."),
    scheduler: str | None = typer.Option(None, "--scheduler", help="local (default with --workers > 1), or the "
                                         "address of a running Dask scheduler (tcp://host:8786) whose workers see "
                                         "the same paths."),
    split_frames: int = typer.Option(240, "--split-frames", help="Split shots longer than N frames into pieces "
                                     "(each a task), each warming the disparity filter up on the frames before it; "
                                     "0 = never."),
) -> None:
    """Retarget a stereo or 2D + depth clip into +-A arcmin on a display, shot by shot, as a stereo video.

    2D + depth: each frame's pair synthesised with its shot's mapping (as vergence synthesize). Stereo:
    each frame matched, its disparity mapped into the budget, the right view re-synthesised from the
    left (or both, --origin center). The mapping is reset at cuts; the disparity is filtered in time on
    static content (the flicker before and after is printed). Audio is copied; the output appears only
    when complete; a clip that breaks mid-way keeps the frames before and exits with code 2. With
    --workers N or --scheduler, each shot (a long one split into pieces) is a Dask task writing its
    own segment (the same output).
    """
    from vergence.video import converted_path
    from vergence.video import convert as _conversion

    display = preset_display(display_preset)
    check_input_kind(kind)
    if fmt not in LAYOUTS:
        raise ValueError(f"--format must be one of {', '.join(LAYOUTS)}; got {fmt!r}")
    if not input_path.exists():
        raise FileNotFoundError(f"INPUT {input_path} does not exist")
    if workers > 1 or (scheduler is not None and scheduler != "local"):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise ValueError("--workers and --scheduler need dask.distributed: pip install 'vergence[dask]'") from None
    run_workers, run_scheduler = workers, scheduler

    def target_of(input_path: Path) -> Path:
        """The output path of ``input_path``: ``--out`` a folder (existing, or a name without a video suffix,
        created) or a file name (its folder created)."""
        folder = out.is_dir() or (not images and not out.suffix)
        with options_named(**_OPTIONS):
            if folder and not out.is_dir():
                try:
                    out.mkdir(parents=True, exist_ok=True)
                except OSError as exc:
                    raise OSError(f"cannot create the --out folder {out}: {exc.strerror or exc}") from None
            target = converted_path(out, input_path, fmt, images=images)
        if not target.parent.is_dir():
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise OSError(f"cannot create the --out folder {target.parent}: {exc.strerror or exc}") from None
        return target

    def one(input_path: Path, kind: str | None, target: Path | None = None) -> None:
        stereo_only = {"method": method, "min_disparity": min_disparity, "max_disparity": max_disparity}
        clip, _ = open_input(input_path, kind, depth=depth, layout=layout, depth_kind=depth_kind,
                             depth_scale=depth_scale, fps=fps, stereo_only=stereo_only)
        if target is None:
            target = target_of(input_path)
        inputs = [input_path, *([depth] if depth is not None else [])]
        check_output_path(target, *inputs)
        from vergence.video import check_new_output

        check_new_output(target, force=force, name="--out", hint="--force")
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        with options_named(**_OPTIONS):
            columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("frames"),
                       TextColumn("{task.fields[fps]}"), TimeRemainingColumn())  # fmt: skip
            # The bar only on a terminal: piped or captured stderr stays empty (errors are one line).
            with Progress(*columns, console=err_console, transient=True, disable=not err_console.is_terminal) as bar:
                tasks: dict[str, tuple[int, float]] = {}

                def progress(phase: str, done: int, total: int) -> None:
                    raise_if_interrupted()
                    if phase not in tasks:
                        tasks[phase] = (bar.add_task(_PHASES[phase], total=total, fps=""), time.perf_counter())
                    task, t0 = tasks[phase]
                    rate = done / max(time.perf_counter() - t0, 1e-9)
                    bar.update(task, completed=done, fps=f"{rate:.1f} fps")

                from vergence.video._segments import work_folder

                work = work_folder(target)
                note_if_interrupted(f"run the same command with --resume to reuse the finished shots in {work}")
                written_before = _stamp(target)
                try:
                    result = _conversion.convert_clip(
                        clip, target, display, budget_arcmin=budget_arcmin, layout=fmt, pixel_format=pixel_format, crf=crf,
                        preset=preset, origin=origin, stabilize=not no_stabilize, threshold=static_threshold,
                        alpha=stabilize_alpha, transition=transition, method=method or "sgbm", min_disparity=min_disparity,
                        max_disparity=max_disparity, floating_window=floating_window, resume=resume, force=force,
                        progress=progress, workers=run_workers, scheduler=run_scheduler, split_frames=split_frames,
                    )  # fmt: skip
                except BaseException:  # the note only where a finished shot is kept, or the output is in place
                    if _stamp(target) not in (None, written_before):  # Ctrl-C while the output was measured
                        note_if_interrupted(f"{target} was written in full; only its measurement was cut short")
                    elif not (work.is_dir() and any(p.name.startswith("shot_") for p in work.iterdir())):
                        note_if_interrupted(None)
                    raise
                note_if_interrupted(None)  # done: nothing left to resume
        print_warnings(result.warnings)
        if as_json:
            print_json(result.to_dict())
            if result.stopped is not None:
                raise ValueError(f"INPUT {input_path.name} stopped after frame {result.frames - 1}: {result.stopped}; "
                                 f"the {result.frames} frames before are in {result.out}")
            return
        for k, shot in enumerate(result.shots):
            console.print(f"shot {k}: frames {shot.start}-{shot.end - 1}, {_shot_line(shot)}", highlight=False)
        before, after = result.flicker_before.mean_px, result.flicker_after.mean_px
        if result.flicker_after.pairs:
            output = result.flicker_output
            seen = "" if not output.pairs else (f"; measured on the output (re-matched, {output.pairs} frame pairs): "
                                                f"{output.mean_px:.4f} px")  # fmt: skip
            console.print(f"flicker on static content: {before:.4f} px before, {after:.4f} px after stabilisation "
                          f"(the filtered disparity, {result.flicker_after.pairs} frame pairs){seen}",
                          highlight=False)  # fmt: skip
        reused = result.frames - result.rendered
        rate = f"{result.rendered / result.seconds:.2f} fps" if result.rendered else "none rendered"
        console.print(f"wrote {result.frames} frames ({rate}{f', {reused} reused' if reused else ''}) to {result.out}",
                      highlight=False)  # fmt: skip
        if result.stopped is not None:
            raise ValueError(f"INPUT {input_path.name} stopped after frame {result.frames - 1}: {result.stopped}; the "
                             f"{result.frames} frames before are in {result.out}")

    if not batch:
        if not input_path.exists():
            raise FileNotFoundError(f"INPUT {input_path} does not exist")
        one(input_path, kind)
        return
    if depth is not None:
        raise ValueError("--depth applies to one INPUT, not to --batch")
    if not input_path.is_dir():
        raise ValueError(f"--batch needs INPUT to be a folder of videos; got {input_path}")
    if out.exists() and not out.is_dir():
        raise ValueError(f"--batch needs --out to be a folder; got the file {out}")
    from vergence.video import VIDEO_SUFFIXES

    files = sorted(p for p in input_path.iterdir() if p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES)
    if not files:
        raise ValueError(f"--batch: no {', '.join(VIDEO_SUFFIXES)} file in {input_path}")
    if not out.is_dir():
        try:
            out.mkdir(parents=True)
        except OSError as exc:
            raise OSError(f"cannot create the --out folder {out}: {exc.strerror or exc}") from None
    # Every output named before any work: two inputs of one name (x_RGBD.mp4, x_LRF_Full_SBS.mp4) or an output that
    # is another input of the batch would lose a file, --force or not.
    targets = {path: target_of(path) for path in files}
    sources = {path.resolve(): path for path in files}
    named: dict[Path, Path] = {}
    for path, target in targets.items():
        if target.resolve() in sources:
            raise ValueError(f"--batch: {path.name} would be written to {target.name}, another input of the batch: give "
                             "another --out folder")
        if target.resolve() in named:
            raise ValueError(f"--batch: {named[target.resolve()].name} and {path.name} would both be written to "
                             f"{target.name}: convert them into different --out folders")
        named[target.resolve()] = path
    cluster = None
    if workers > 1 and scheduler in (None, "local"):  # one cluster for every file
        from vergence.video._shots import local_cluster

        cluster = local_cluster(workers)
        run_workers, run_scheduler = 1, cluster.scheduler_address
    skipped: list[str] = []
    kept = 0
    try:
        for path in files:
            console.print(f"{path.name}:", highlight=False)
            target = targets[path]
            if resume and not force and (target.is_file() or (target.is_dir() and any(target.iterdir()))):
                # an earlier run of the batch finished it (outputs appear only when complete)
                console.print(f"kept {target.name} (written by an earlier run; --force converts it again)",
                              highlight=False)  # fmt: skip
                kept += 1
                continue
            try:
                one(path, kind, target)
            except (ValueError, TypeError, OSError) as exc:
                if not skip_errors:
                    raise type(exc)(f"{path.name}: {exc}") from exc
                err_console.print(f"skipped {path.name}: {exc}", highlight=False, soft_wrap=True)
                skipped.append(path.name)
    finally:
        if cluster is not None:
            cluster.close()
    console.print(f"converted {len(files) - len(skipped)} of {len(files)} files"
                  f"{f' ({kept} kept from an earlier run)' if kept else ''}", highlight=False)  # fmt: skip
    if skipped:
        raise ValueError(f"--skip-errors: {len(skipped)} of {len(files)} files skipped ({', '.join(skipped)})")


def _shot_line(shot) -> str:
    """A converted shot in one line: every disparity ``x_left - x_right`` in px, positive in front of the screen."""
    lo, hi = shot.disparity_out_px
    if shot.search is not None:
        (s_lo, s_hi), bound = shot.search["search_px"], " ".join(shot.search["on_bound"])
        source = (f"disparity {shot.range_in[0]:+.2f} .. {shot.range_in[1]:+.2f} px (1-99 %, searched {s_lo} .. "
                  f"{s_hi} px{', on bound: ' + bound if bound else ''})")  # fmt: skip
    else:
        source = f"nearness {shot.range_in[0]:.4g} .. {shot.range_in[1]:.4g}"
    measured = ""
    if shot.output is not None:
        d = shot.output.disparity_px
        used = "" if shot.budget_used is None else f"{100 * shot.budget_used:.0f} % of the plan, "
        measured = (f", measured on the output {d['p1']:+.2f} .. {d['p99']:+.2f} px (1-99 %, {used}rank correlation "
                    f"with the source {shot.output.rank_correlation:.2f})")  # fmt: skip
    window = ""
    if shot.window is not None and (shot.window["left_px"] or shot.window["right_px"]):
        masked = ", ".join(f"{e} {shot.window[f'{e}_px']} px" for e in ("left", "right") if shot.window[f"{e}_px"])
        window = f"; floating window: {masked}"
    note = " (reused)" if shot.reused else ""
    return (f"{source} -> {lo:+.2f} .. {hi:+.2f} px planned{measured} (psi slope {shot.mapping.gain:.4g})"
            f"{window}{note}")
