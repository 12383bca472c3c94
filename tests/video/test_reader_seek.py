"""Seeking: ``frames(start, stop)`` decodes from the keyframe at or before ``start``, bit-equal to a decode from frame 0.

Every clip here has a keyframe every GOP frames (x264's ``g``) and, unless named otherwise, B-frames (x264's
default ``medium`` preset codes a texture in slow motion mostly as B-frames; checked). The reference is the
decode from frame 0 (``frames()``, which never seeks); the count of frames out of the decoder shows whether a
call sought (``FrameReader._decoded`` wrapped), against the keyframes PyAV reports.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vergence.video import VideoWriter, open_depth_clip, open_frames, open_stereo
from vergence.video.reader import FrameReader

FRAMES, GOP, H, W = 40, 8, 48, 64
# Starts around the keyframes 0, 8, 16, 24, 32: the first frames, a keyframe, just before and after one, the last.
STARTS = (0, 1, 2, 7, 8, 9, 15, 16, 17, 23, 24, 31, 33, 38, 39)


def _moving_frames(n: int) -> list[np.ndarray]:
    """A smoothed random texture moving 2 px per frame, uint8 ``(H, W, 3)``."""
    rng = np.random.default_rng(0)
    texture = rng.integers(0, 256, (H, W + 2 * n, 3)).astype(np.int32)
    texture = ((texture + np.roll(texture, 1, 0) + np.roll(texture, 1, 1)) // 3).astype(np.uint8)
    return [np.ascontiguousarray(texture[:, 2 * k:2 * k + W]) for k in range(n)]


def _write(path, n=FRAMES, fps=24, crf=18, **x264):
    video = VideoWriter(path, fps=fps, width=W, height=H, crf=crf)
    video._x264_options = {"g": str(GOP), "sc_threshold": "0", **x264}  # keyframes at multiples of GOP only
    with video:
        for frame in _moving_frames(n):
            video.write(frame)
    return path


def _write_timed(path, pts_48ths):
    """H.264 frames at the given timestamps (1/48 s), written with PyAV: clips whose timestamps are off the grid."""
    import av

    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=24)
        stream.width, stream.height, stream.pix_fmt = W, H, "yuv420p"
        stream.codec_context.time_base = Fraction(1, 48)
        stream.options = {"g": str(GOP), "sc_threshold": "0"}
        for image, pts in zip(_moving_frames(len(pts_48ths)), pts_48ths):
            frame = av.VideoFrame.from_ndarray(image, format="rgb24")
            frame.pts, frame.time_base = pts, Fraction(1, 48)
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode(None):
            out.mux(packet)
    return path


@pytest.fixture(scope="module")
def clips(tmp_path_factory):
    folder = tmp_path_factory.mktemp("seek")
    return {
        "mp4": _write(folder / "clip.mp4"),
        "mkv": _write(folder / "clip.mkv"),
        "mkv-ntsc": _write(folder / "ntsc.mkv", fps=24000 / 1001),  # milliseconds off the 1001/24000 s grid
        "mp4-no-b": _write(folder / "no_b.mp4", bf="0"),
    }


@pytest.fixture(scope="module")
def full(clips):
    """Each clip decoded from frame 0."""
    return {name: list(open_frames(path).frames()) for name, path in clips.items()}


def _keyframes_and_b(path) -> tuple[list[int], int]:
    import av
    from av.video.frame import PictureType

    with av.open(str(path)) as container:
        types = [(frame.key_frame, int(frame.pict_type)) for frame in container.decode(video=0)]
    return [k for k, (key, _) in enumerate(types) if key], sum(t == int(PictureType.B) for _, t in types)


@pytest.fixture
def decoded(monkeypatch):
    """A list whose length is the number of frames out of the decoder since the test began."""
    seen = []
    plain = FrameReader._decoded

    def counted(container, stream):
        for frame in plain(container, stream):
            seen.append(frame.pts)
            yield frame

    monkeypatch.setattr(FrameReader, "_decoded", staticmethod(counted))
    return seen


def _assert_frames_equal(got, expected):
    assert len(got) == len(expected)
    for g, e in zip(got, expected):
        assert g.dtype == np.float32
        np.testing.assert_array_equal(g, e)


@pytest.mark.parametrize("name", ["mp4", "mkv", "mkv-ntsc", "mp4-no-b"])
def test_a_range_is_the_slice_of_the_decode_from_frame_0(clips, full, name, decoded):
    keyframes, b_frames = _keyframes_and_b(clips[name])
    assert keyframes == list(range(0, FRAMES, GOP))
    assert (b_frames == 0) == (name == "mp4-no-b")  # the others do test reordered frames
    reader = open_frames(clips[name])
    for start in STARTS:
        for stop in sorted({start + 1, min(start + 3, FRAMES), FRAMES}):
            decoded.clear()
            _assert_frames_equal(list(reader.frames(start, stop)), full[name][start:stop])
            # decoded from the keyframe at or before start, not from frame 0
            assert len(decoded) == stop - max(k for k in keyframes if k <= start), (start, stop)


@settings(max_examples=25, deadline=None)
@given(start=st.integers(0, FRAMES - 1), length=st.integers(1, 12), name=st.sampled_from(["mp4", "mkv"]))
def test_any_range_is_the_slice_of_the_decode_from_frame_0(clips, full, start, length, name):
    stop = min(start + length, FRAMES)
    _assert_frames_equal(list(open_frames(clips[name]).frames(start, stop)), full[name][start:stop])


def test_the_last_frames_of_a_long_clip_decode_one_gop(tmp_path, decoded):
    n = 240
    reader = open_frames(_write(tmp_path / "long.mp4", n=n))
    last = list(reader.frames(n - 2, n))
    assert len(decoded) == n - 232  # frames 232 to 239: the last keyframe is 232 = 29 GOP
    decoded.clear()
    _assert_frames_equal(last, list(reader.frames())[n - 2:])
    assert len(decoded) == n


def test_the_frame_rate_option_does_not_move_the_frames(clips, full, decoded):
    # fps=50 overrides the header's 24 for the caller; the timestamps still count in the stream's own rate
    reader = open_frames(clips["mp4"], fps=50)
    _assert_frames_equal(list(reader.frames(20, 26)), full["mp4"][20:26])
    assert len(decoded) == 26 - 16


def test_off_grid_timestamps_decode_from_frame_0(tmp_path, decoded):
    # a gap of one frame after frame 20: the last frame's timestamp is that of frame 40 of 40
    gap = _write_timed(tmp_path / "gap.mkv", [2 * k + (2 if k >= 20 else 0) for k in range(FRAMES)])
    # a variable frame rate: 24 frames/s, then 12
    vfr = _write_timed(tmp_path / "vfr.mkv", [2 * k if k < 20 else 40 + 4 * (k - 20) for k in range(FRAMES)])
    for path in (gap, vfr):
        reader = open_frames(path)
        reference = list(reader.frames())
        for start in (1, 9, 30, 38):
            decoded.clear()
            _assert_frames_equal(list(reader.frames(start, start + 2)), reference[start:start + 2])
            assert len(decoded) == start + 2, (path.name, start)


def test_a_gap_found_after_the_seek_goes_back_to_frame_0(tmp_path, decoded):
    # on the grid at both ends, frames 10 to 19 one frame late, frame 20 half a frame late: a seek to
    # frame 9 lands on keyframe 8, frame 10's timestamp says 11, and the reader decodes again from frame 0
    pts = [2 * k + (2 if 10 <= k < 20 else 1 if k == 20 else 0) for k in range(FRAMES)]
    reader = open_frames(_write_timed(tmp_path / "late.mkv", pts))
    reference = list(reader.frames())
    for start, stop in ((9, 12), (12, 14), (16, 22), (30, 32)):
        decoded.clear()
        _assert_frames_equal(list(reader.frames(start, stop)), reference[start:stop])
        # 8, 9, 10 after the seek (keyframe 16's timestamp is past frame 16's slot), then 0 to stop - 1
        expected = stop - 24 if start >= 24 else 3 + stop
        assert len(decoded) == expected, (start, stop)


def test_sources_read_ranges_in_step(clips, full):
    depth = open_depth_clip(clips["mp4"], depth=clips["mkv"], kind="inverse")
    pairs = list(depth.pairs())
    for start, stop in ((9, 12), (31, 40)):
        for (image, d), (image_ref, d_ref) in zip(depth.pairs(start, stop), pairs[start:stop], strict=True):
            np.testing.assert_array_equal(image, image_ref)
            np.testing.assert_array_equal(d, d_ref)
    stereo = open_stereo(clips["mkv"], layout="sbs")
    lefts = [left for left, _ in stereo.pairs()]
    _assert_frames_equal(list(stereo.lefts(17, 20)), lefts[17:20])


def test_a_truncated_clip_names_the_frame_where_it_stops(tmp_path):
    import av

    whole = _write(tmp_path / "whole.mp4", crf=0)  # faststart: the index at the front announces 40 frames
    data = whole.read_bytes()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    decodable = 0
    try:
        with av.open(str(cut)) as container:
            for _ in container.decode(video=0):
                decodable += 1
    except av.FFmpegError:
        pass
    assert 0 < decodable < FRAMES
    reader = open_frames(cut)
    assert reader.info.frames == FRAMES
    for start in (0, 1, 9, decodable - 1, decodable, FRAMES - 1):
        with pytest.raises(ValueError, match=rf"^video .*cut.mp4 (stops after {decodable} frames; its header "
                                             rf"announces 40: truncated|cannot be decoded past frame {decodable} "
                                             rf"of 40 \(.*\): damaged or truncated)$"):
            list(reader.frames(start))


def test_a_decoding_error_after_a_seek_names_its_frame(clips, monkeypatch):
    import av

    plain = FrameReader._decoded

    def failing_after(n):
        def decoded(container, stream):
            for k, frame in enumerate(plain(container, stream)):
                if k == n:
                    raise av.error.InvalidDataError(1094995529, "Invalid data found when processing input")
                yield frame
        return staticmethod(decoded)

    reader = open_frames(clips["mp4"])
    monkeypatch.setattr(FrameReader, "_decoded", failing_after(3))
    message = r"^video .*clip.mp4 cannot be decoded past frame {} of 40 \(Invalid data .*\): damaged or truncated$"
    with pytest.raises(ValueError, match=message.format(19)):  # from keyframe 16: 16, 17, 18, then the error
        list(reader.frames(17, 30))
    with pytest.raises(ValueError, match=message.format(3)):  # from frame 0
        list(reader.frames(0, 30))
    # an error before the first frame after the seek: decoded again from frame 0, which names frame 0
    monkeypatch.setattr(FrameReader, "_decoded", failing_after(0))
    with pytest.raises(ValueError, match=message.format(0)):
        list(reader.frames(17, 30))


def test_a_consumer_that_stops_early_after_a_seek(clips, full):
    reader = open_frames(clips["mkv"])
    for start in (9, 33, 39):
        for _ in range(5):
            frames = reader.frames(start)
            np.testing.assert_array_equal(next(frames), full["mkv"][start])
            frames.close()
    assert list(reader.frames(20, 20)) == []


@pytest.mark.parametrize("suffix", [".mkv", ".mp4"])
def test_a_cut_file_is_never_read_as_a_whole_clip(tmp_path, suffix):
    """Cut at several points, an MKV (no frame count in its header: the packets are counted, checked against its
    duration) or an MP4 is refused when opened or stops with "truncated"; never read as a shorter complete clip."""
    whole = _write(tmp_path / f"whole{suffix}", crf=0)
    assert open_frames(whole).info.frames == FRAMES and len(list(open_frames(whole).frames(0))) == FRAMES
    data = whole.read_bytes()
    refused_at_open = 0
    for share in (0.2, 0.5, 0.8, 0.95):
        cut = tmp_path / f"cut{suffix}"
        cut.write_bytes(data[: int(len(data) * share)])
        try:
            reader = open_frames(cut)
        except ValueError as exc:
            assert "truncated" in str(exc) or "cannot read video" in str(exc), exc
            refused_at_open += 1
            continue
        assert reader.info.frames == FRAMES, share
        with pytest.raises(ValueError, match=r"truncated$"):
            list(reader.frames(0))
    if suffix == ".mkv":  # the header comes first: every cut opens, and says where it stops
        assert refused_at_open == 0
