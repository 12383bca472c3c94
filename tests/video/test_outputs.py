"""Nothing lost (issue 28): an output that exists is refused unless the caller says to replace it, at the start and
at the commit (vergence.video.outputs.check_new_output, vergence.io.atomic_write(replace=False))."""

from __future__ import annotations

import pytest

from vergence.io.atomic import atomic_write
from vergence.video.outputs import check_new_output


def test_an_existing_file_or_a_folder_holding_files_is_refused(tmp_path):
    clip = tmp_path / "x_LRF_Full_SBS.mp4"
    clip.write_bytes(b"another clip")
    with pytest.raises(FileExistsError, match=r"^--out .*x_LRF_Full_SBS.mp4 exists: give --force to replace it$"):
        check_new_output(clip, name="--out", hint="--force")
    check_new_output(clip, force=True)
    frames = tmp_path / "frames"
    frames.mkdir()
    check_new_output(frames)  # empty: nothing in it is lost
    (frames / "frame_000000.png").write_bytes(b"png")
    with pytest.raises(FileExistsError, match="exists and holds files: give force=True"):
        check_new_output(frames)
    link = tmp_path / "dangling.mp4"
    link.symlink_to(tmp_path / "nowhere.mp4")
    with pytest.raises(FileExistsError):  # a dangling link is a name taken too
        check_new_output(link)
    check_new_output(tmp_path / "new.mp4")
    assert clip.read_bytes() == b"another clip"


def test_atomic_write_without_replace_refuses_at_the_start_and_at_the_commit(tmp_path):
    out = tmp_path / "o.mp4"
    out.write_bytes(b"old")
    with pytest.raises(FileExistsError, match="it exists"), atomic_write(out, replace=False) as tmp:
        tmp.write_bytes(b"new")
    assert out.read_bytes() == b"old"
    late = tmp_path / "late.mp4"
    with pytest.raises(FileExistsError, match="it exists"), atomic_write(late, replace=False) as tmp:
        tmp.write_bytes(b"new")
        late.write_bytes(b"written meanwhile by someone else")
    assert late.read_bytes() == b"written meanwhile by someone else"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["late.mp4", "o.mp4"]  # no temporary file left
    with atomic_write(tmp_path / "fresh.mp4", replace=False) as tmp:
        tmp.write_bytes(b"new")
    assert (tmp_path / "fresh.mp4").read_bytes() == b"new"
    with atomic_write(out) as tmp:  # the default replaces, as before
        tmp.write_bytes(b"replaced")
    assert out.read_bytes() == b"replaced"
