"""Shots as Dask tasks (vergence.video._shots): a 2-worker LocalCluster writes the serial run's bytes."""

from __future__ import annotations

import pytest

pytest.importorskip("distributed", reason="dask.distributed is not installed: pip install 'vergence[dask]'")

from vergence.video import convert_clip, open_depth_clip, open_stereo  # noqa: E402
from vergence.viewing import Display  # noqa: E402

DISPLAY = Display.preset("tv-55")


def _frames(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# Each shot (or piece: split 4 cuts the 12-frame shots into 3) is a task of matching (stereo), then of rendering;
# a transition ramps between the shots' psi, all known once the matching is done.
@pytest.mark.parametrize(("kind", "transition", "split"), [("2d+depth", 0.0, 240), ("stereo", 0.0, 240),
                                                          ("stereo", 3.0, 240), ("2d+depth", 0.0, 4), ("stereo", 0.0, 4)])
def test_dask_png_frames_are_byte_identical_to_the_serial_ones(clips, tmp_path, kind, transition, split):
    # PNG frames, one file each: a difference is found frame by frame (the MP4 bytes are compared below).
    def clip():
        return open_depth_clip(clips.rgbd) if kind == "2d+depth" else open_stereo(clips.stereo)

    serial = convert_clip(clip(), tmp_path / "serial", DISPLAY, transition=transition, split_frames=split)
    dask = convert_clip(clip(), tmp_path / "dask", DISPLAY, transition=transition, workers=2, split_frames=split)
    a, b = _frames(serial.out), _frames(dask.out)
    assert len(a) == clips.frames and list(a) == list(b)
    assert all(a[k] == b[k] for k in a)
    assert [(s.start, s.end, s.mapping.gain) for s in serial.shots] == [(s.start, s.end, s.mapping.gain)
                                                                          for s in dask.shots]  # fmt: skip
    assert dask.flicker_after.mean_px == pytest.approx(serial.flicker_after.mean_px, rel=1e-12)
    assert not (tmp_path / ".dask.parts").exists()


@pytest.mark.parametrize("kind", ["2d+depth", "stereo"])
def test_dask_mp4_is_byte_identical_to_the_serial_one(clips, tmp_path, kind):
    """Issue 28: the H.264 files too (x264 given the same frames and options writes the same bytes here; the
    README said it was not reproducible)."""
    def clip():
        return open_depth_clip(clips.rgbd) if kind == "2d+depth" else open_stereo(clips.stereo)

    serial = convert_clip(clip(), tmp_path / "serial_LRF_Full_SBS.mp4", DISPLAY, preset="ultrafast")
    dask = convert_clip(clip(), tmp_path / "dask_LRF_Full_SBS.mp4", DISPLAY, preset="ultrafast", workers=2)
    assert serial.out.stat().st_size > 0 and serial.out.read_bytes() == dask.out.read_bytes()


def test_bad_scheduler_address_is_one_clear_error(clips, tmp_path, monkeypatch):
    from vergence.video import _shots

    monkeypatch.setattr(_shots, "CONNECT_TIMEOUT_S", 1)
    with pytest.raises(ValueError, match="cannot reach the Dask scheduler"):
        convert_clip(open_depth_clip(clips.rgbd), tmp_path / "out", DISPLAY, scheduler="tcp://127.0.0.1:9")
    assert not any(tmp_path.iterdir())  # nothing left behind


def test_bad_workers_is_refused(clips, tmp_path):
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        convert_clip(open_depth_clip(clips.rgbd), tmp_path / "out", DISPLAY, workers=0)


def test_dask_resume_after_an_interruption_gives_the_serial_frames(clips, tmp_path):
    out = tmp_path / "res"

    def stop_at_first_shot(phase, done, total):
        if phase == "converting":
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        convert_clip(open_stereo(clips.stereo), out, DISPLAY, workers=2, progress=stop_at_first_shot)
    work = tmp_path / ".res.parts"
    assert not out.exists() and list(work.glob("shot_*"))  # the finished shot stays (the other may have finished too)
    assert [p.name for p in tmp_path.iterdir()] == [".res.parts"]  # no partial output beside it
    r = convert_clip(open_stereo(clips.stereo), out, DISPLAY, workers=2, resume=True)
    assert any(s.reused for s in r.shots) and not work.exists()
    serial = convert_clip(open_stereo(clips.stereo), tmp_path / "serial", DISPLAY)
    assert _frames(r.out) == _frames(serial.out)


def test_local_workers_ignore_ctrl_c_and_log_nothing():
    """Ctrl-C at a terminal reaches the whole process group: the workers ignore it (this process stops them), so
    no worker traceback or distributed log line comes before our "interrupted" line (issue 28)."""
    import logging
    import signal

    from distributed import Client

    from vergence.video._shots import local_cluster

    before = signal.getsignal(signal.SIGINT)
    cluster = local_cluster(1)
    try:
        assert signal.getsignal(signal.SIGINT) is before  # restored in this process
        with Client(cluster) as client:
            handlers = client.run(lambda: str(signal.getsignal(signal.SIGINT)))
        assert list(handlers.values()) == [str(signal.SIG_IGN)]
        assert logging.getLogger("distributed").getEffectiveLevel() >= logging.CRITICAL
    finally:
        cluster.close()
