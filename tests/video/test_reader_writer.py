"""Frames in and out: the atomic H.264 writer, the streaming reader, folders, and each refusal."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.io import write_image
from vergence.video import (
    DEFAULT_FOLDER_FPS,
    VideoInfo,
    VideoWriter,
    open_depth_clip,
    open_frames,
    open_stereo,
)

# 4:4:4 at crf 0 is lossless in YUV; the RGB -> YUV -> RGB round trip of 8-bit values moves a level
# by at most 2 (BT.601 integer matrices).
LOSSLESS_444_ATOL = 2.5 / 255
# 4:2:0 at crf 0 on ramps of 8 levels per pixel: the chroma of each 2x2 block is one average, which
# moves a pixel by up to 11 levels (measured); a level more for the encoder.
SMOOTH_420_ATOL = 12.0 / 255


def _smooth_frames(n, h=16, w=32):
    y, x = np.mgrid[0:h, 0:w] / np.array([h, w])[:, None, None]
    return [np.stack([x, y, np.full_like(x, k / n)], axis=2).astype(np.float32) for k in range(n)]


def _write(path, frames, **kw):
    h, w = frames[0].shape[:2]
    with VideoWriter(path, fps=kw.pop("fps", 24), width=w, height=h, **kw) as video:
        for f in frames:
            video.write(f)
    return path


@pytest.mark.parametrize("pixel_format, atol", [("yuv444p", LOSSLESS_444_ATOL), ("yuv420p", SMOOTH_420_ATOL)])
def test_frames_written_read_back(tmp_path, pixel_format, atol):
    frames = _smooth_frames(5)
    path = _write(tmp_path / "clip.mkv", frames, crf=0, pixel_format=pixel_format, fps=30)
    reader = open_frames(path)
    assert reader.info == VideoInfo(frames=5, fps=30.0, width=32, height=16)
    got = list(reader.frames())
    assert len(got) == 5 and all(g.dtype == np.float32 and g.shape == (16, 32, 3) for g in got)
    for g, f in zip(got, frames):
        np.testing.assert_allclose(g, f, atol=atol)
    middle = list(reader.frames(2, 4))  # a range, streamed
    np.testing.assert_array_equal(middle[0], got[2])
    assert len(middle) == 2


def test_writer_is_atomic_and_refuses_an_empty_video(tmp_path):
    target = tmp_path / "out.mp4"
    with pytest.raises(RuntimeError, match="stop"):
        with VideoWriter(target, fps=24, width=8, height=8) as video:
            video.write(np.zeros((8, 8, 3), np.float32))
            raise RuntimeError("stop")
    with pytest.raises(ValueError, match="no frame was written to .*out.mp4: a video needs at least one"):
        with VideoWriter(target, fps=24, width=8, height=8):
            pass
    assert list(tmp_path.iterdir()) == []  # neither the target nor a temporary file


def test_writer_refusals(tmp_path):
    with pytest.raises(ValueError, match="yuv420p needs an even frame size; got 9x8"):
        VideoWriter(tmp_path / "a.mp4", fps=24, width=9, height=8)
    VideoWriter(tmp_path / "a.mp4", fps=24, width=9, height=8, pixel_format="yuv444p")  # 4:4:4 takes odd sizes
    with pytest.raises(ValueError, match="pixel_format must be one of yuv420p, yuv444p; got 'rgb24'"):
        VideoWriter(tmp_path / "a.mp4", fps=24, width=8, height=8, pixel_format="rgb24")
    with pytest.raises(ValueError, match="path must be a .mp4, .mkv or .mov file; got 'a.avi'"):
        VideoWriter(tmp_path / "a.avi", fps=24, width=8, height=8)
    with pytest.raises(ValueError, match="fps must be a finite number > 0; got 0"):
        VideoWriter(tmp_path / "a.mp4", fps=0, width=8, height=8)
    with VideoWriter(tmp_path / "b.mp4", fps=24, width=8, height=8) as video:
        with pytest.raises(ValueError, match=r"frame must have shape \(8, 8, 3\); got \(8, 9, 3\)"):
            video.write(np.zeros((8, 9, 3)))
        with pytest.raises(ValueError, match=r"frame must hold finite values in \[0, 1\]"):
            video.write(np.full((8, 8, 3), 1.5))
        video.write(np.zeros((8, 8, 3), np.uint8))


def test_audio_is_copied(tmp_path):
    import av

    source = tmp_path / "sound.mka"
    with av.open(str(source), "w") as out:
        stream = out.add_stream("aac", rate=48000)
        samples = (0.1 * np.sin(np.linspace(0, 440 * 2 * np.pi, 48000))).astype(np.float32)[None, :]
        frame = av.AudioFrame.from_ndarray(samples, format="fltp", layout="mono")
        frame.sample_rate = 48000
        for packet in stream.encode(frame):
            out.mux(packet)
        for packet in stream.encode(None):
            out.mux(packet)
    path = _write(tmp_path / "with_audio.mp4", _smooth_frames(3), audio_from=source)
    with av.open(str(path)) as container:
        assert len(container.streams.audio) == 1 and container.streams.audio[0].codec_context.name == "aac"
    assert open_frames(path).info.frames == 3
    silent = _write(tmp_path / "silent.mp4", _smooth_frames(2))
    with pytest.raises(ValueError, match="audio_from .*silent.mp4 holds no audio stream"):
        _write(tmp_path / "x.mp4", _smooth_frames(2), audio_from=silent)
    assert not (tmp_path / "x.mp4").exists()


def test_a_folder_is_read_in_number_order(tmp_path):
    for k in (10, 9, 11):
        write_image(tmp_path / f"frame_{k}.png", np.full((4, 6, 3), k / 20.0))
    (tmp_path / "notes.txt").write_text("not a frame")
    reader = open_frames(tmp_path)
    assert reader.info == VideoInfo(frames=3, fps=DEFAULT_FOLDER_FPS, width=6, height=4)
    assert [round(float(f[0, 0, 0]) * 20) for f in reader.frames()] == [9, 10, 11]
    assert open_frames(tmp_path, fps=30).info.fps == 30.0
    single = open_frames(tmp_path / "frame_9.png")  # one image: a clip of one frame
    assert single.info.frames == 1


def test_folder_refusals(tmp_path):
    with pytest.raises(ValueError, match="holds no numbered frames .*: a zero-length clip"):
        open_frames(tmp_path)
    write_image(tmp_path / "a_1.png", np.zeros((4, 6, 3)))
    write_image(tmp_path / "b_01.png", np.zeros((4, 6, 3)))
    with pytest.raises(ValueError, match="holds two frames numbered 1: "):
        open_frames(tmp_path)
    with pytest.raises(FileNotFoundError, match="no such video or frame folder"):
        open_frames(tmp_path / "missing.mp4")


def test_unreadable_zero_length_and_truncated_videos_are_refused(tmp_path):
    import av

    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"not a video at all")
    with pytest.raises(ValueError, match=r"^cannot read video .*junk.mp4: "):
        open_frames(junk)
    empty = tmp_path / "empty.mkv"
    with av.open(str(empty), "w") as out:  # a header, no frame
        stream = out.add_stream("libx264", rate=24)
        stream.width, stream.height, stream.pix_fmt = 16, 16, "yuv420p"
        out.start_encoding()
    with pytest.raises(ValueError, match="empty.mkv ends before its first frame: a zero-length"):
        open_frames(empty)
    # a streamable container cut in the middle: the header's count is gone, the frames stop early
    whole = _write(tmp_path / "whole_LRF_Full_SBS.mp4", _smooth_frames(24, 32, 64), crf=0)
    data = whole.read_bytes()
    cut = tmp_path / "cut_LRF_Full_SBS.mp4"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    reader = open_frames(cut)  # faststart: the index is at the front and still announces 24 frames
    assert reader.info.frames == 24
    with pytest.raises(ValueError, match=r"cut_LRF_Full_SBS.mp4 (stops after \d+ frames; its header announces 24: "
                                         r"truncated|cannot be decoded past frame \d+ of 24)"):
        list(reader.frames())


def test_stereo_refusals(tmp_path):
    frames = _smooth_frames(2, 16, 32)
    plain = _write(tmp_path / "plain.mp4", frames)
    with pytest.raises(ValueError, match="cannot guess the stereo layout of plain.mp4: its name carries no tag"):
        open_stereo(plain)
    assert open_stereo(plain, layout="tb").width == 32  # the option overrides
    with pytest.raises(ValueError, match="layout must be one of sbs, half-sbs, tb, half-tb; got 'rgbd'"):
        open_stereo(plain, layout="rgbd")
    rgbd = _write(tmp_path / "clip_RGBD.mp4", frames)
    with pytest.raises(ValueError, match="is tagged 'rgbd' \\(colour \\+ depth\\), not a stereo layout"):
        open_stereo(rgbd)
    for k in range(2):
        write_image(tmp_path / f"odd_Half_SBS_{k}.png", np.zeros((4, 7, 3)))
    folder = tmp_path / "odd_Half_SBS"
    folder.mkdir()
    for k in range(2):
        (tmp_path / f"odd_Half_SBS_{k}.png").rename(folder / f"f_{k}.png")
    with pytest.raises(ValueError, match=r"layout half-sbs \(side by side\) needs an even frame width; got 7x4"):
        open_stereo(folder)


def test_depth_clip_refusals(tmp_path):
    colour = _write(tmp_path / "colour.mp4", _smooth_frames(3))
    shorter = _write(tmp_path / "depth_short.mp4", _smooth_frames(2))
    smaller = _write(tmp_path / "depth_small.mp4", _smooth_frames(3, 16, 16))
    with pytest.raises(ValueError, match="depth clip depth_short.mp4 has 2 frames; the colour clip colour.mp4 has 3"):
        open_depth_clip(colour, depth=shorter)
    with pytest.raises(ValueError, match="depth clip depth_small.mp4 is 16x16; the colour clip colour.mp4 is 32x16"):
        open_depth_clip(colour, depth=smaller)
    with pytest.raises(ValueError, match="metric depth stored as video frames needs a scale"):
        open_depth_clip(colour, depth=colour, kind="metric")
    with pytest.raises(ValueError, match="kind must be one of disparity, inverse, metric; got 'z'"):
        open_depth_clip(colour, depth=colour, kind="z")
    clip = open_depth_clip(colour, depth=colour, kind="metric", scale=100.0)
    image, depth = next(clip.pairs())
    assert image.shape == (16, 32, 3) and depth.shape == (16, 32) and depth.dtype == np.float32


def test_a_consumer_that_stops_early_does_not_hang(clips):
    # Closing a decoder with frames in flight hung FFmpeg's frame threads (thread_type="AUTO", within 5
    # tries on the rendered clip): run in a child process so that a regression fails on the timeout
    # instead of hanging the suite.
    import subprocess
    import sys

    path = clips.stereo
    code = ("import sys; from vergence.video import open_frames\n"
            "for _ in range(30): next(open_frames(sys.argv[1]).frames())\n"
            "print('ok')")
    done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "ok", done.stderr


def test_without_pyav_the_error_names_the_extra(monkeypatch, tmp_path):
    import sys

    monkeypatch.setitem(sys.modules, "av", None)  # `import av` now raises ImportError
    with pytest.raises(ImportError, match=r"install the video extra, pip install 'vergence\[video\]'"):
        VideoWriter(tmp_path / "a.mp4", fps=24, width=8, height=8).__enter__()
    # image folders need no decoder
    write_image(tmp_path / "f_1.png", np.zeros((4, 6, 3)))
    assert open_frames(tmp_path).info.frames == 1
