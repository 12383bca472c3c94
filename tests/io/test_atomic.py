"""Atomic writes and strict JSON."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vergence.io import atomic_write, write_json


def test_atomic_write_renames_on_success_and_keeps_the_extension(tmp_path):
    target = tmp_path / "out.png"
    with atomic_write(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".png" and tmp.name.startswith(".out.tmp-")
        assert not tmp.exists() and not target.exists()
        tmp.write_bytes(b"new")
    assert target.read_bytes() == b"new"
    assert [p.name for p in tmp_path.iterdir()] == ["out.png"]


def test_atomic_write_replaces_an_existing_file(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with atomic_write(target) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"


def test_failure_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="boom"), atomic_write(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_block_that_writes_nothing_is_an_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="the writer created no file"), atomic_write(tmp_path / "a.txt"):
        pass
    assert list(tmp_path.iterdir()) == []


def test_bad_output_paths(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"folder .*missing does not exist"), atomic_write(
        tmp_path / "missing" / "a.txt"
    ):
        pass
    with pytest.raises(IsADirectoryError, match="it is a directory"), atomic_write(tmp_path):
        pass
    with pytest.raises(TypeError, match="path must be a str or os.PathLike; got NoneType"), atomic_write(None):
        pass


def test_write_json_round_trip_with_numpy_values(tmp_path):
    target = tmp_path / "r.json"
    obj = {"a": np.float32(0.5), "b": np.int64(3), "c": np.arange(3), "d": [1.25, None, True], "p": tmp_path}
    write_json(target, obj)
    text = target.read_text()
    assert text.endswith("}\n")
    assert json.loads(text) == {"a": 0.5, "b": 3, "c": [0, 1, 2], "d": [1.25, None, True], "p": str(tmp_path)}


@pytest.mark.parametrize("bad", [math.nan, math.inf, np.array([1.0, np.nan]), np.float64(-np.inf)])
def test_write_json_refuses_non_finite_numbers(tmp_path, bad):
    target = tmp_path / "r.json"
    with pytest.raises(ValueError, match=r"cannot write .*r\.json as JSON: .*NaN and inf are not valid JSON"):
        write_json(target, {"x": bad})
    assert list(tmp_path.iterdir()) == []


def test_write_json_refuses_unserialisable_objects(tmp_path):
    with pytest.raises(TypeError, match="object of type set is not JSON serialisable"):
        write_json(tmp_path / "r.json", {"x": {1, 2}})


def test_atomic_folder_all_or_nothing(tmp_path):
    from vergence.io import atomic_folder

    with pytest.raises(KeyboardInterrupt):
        with atomic_folder(tmp_path / "new" / "out") as tmp:
            (tmp / "a.txt").write_text("half")
            raise KeyboardInterrupt
    assert list((tmp_path / "new").iterdir()) == []  # neither the folder nor its temporary twin
    with atomic_folder(tmp_path / "new" / "out") as tmp:
        (tmp / "a.txt").write_text("one")
    existing = tmp_path / "new" / "out"
    (existing / "keep.txt").write_text("mine")
    with atomic_folder(existing) as tmp:
        (tmp / "a.txt").write_text("two")
    assert sorted(p.name for p in existing.iterdir()) == ["a.txt", "keep.txt"]
    assert (existing / "a.txt").read_text() == "two"
    assert [p.name for p in (tmp_path / "new").iterdir()] == ["out"]
    (tmp_path / "file").write_text("x")
    with pytest.raises(NotADirectoryError, match="it exists and is not a folder"):
        with atomic_folder(tmp_path / "file"):
            pass


# Issue 9: filesystem errors leaked errno text and our hidden temporary names
# ("Read-only file system: '.b.tmp-7564498b5275.png'", "[Errno 17] File exists").
def test_filesystem_errors_name_the_output_not_the_temporary_file(tmp_path, monkeypatch):
    import errno
    import os

    from vergence.io import atomic_folder, write_image

    def read_only(src, dst):
        raise OSError(errno.EROFS, "Read-only file system", str(src))

    monkeypatch.setattr(os, "replace", read_only)
    with pytest.raises(OSError) as info:
        write_image(tmp_path / "b.png", np.zeros((2, 2)))
    assert str(info.value) == f"cannot write {tmp_path / 'b.png'}: Read-only file system"
    assert info.value.errno == errno.EROFS
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    (tmp_path / "file").write_text("x")
    with pytest.raises(OSError) as info:
        with atomic_folder(tmp_path / "file" / "out"):
            pass
    assert str(info.value).startswith(f"cannot create the output folder {tmp_path / 'file' / 'out'}: ")
    assert "Errno" not in str(info.value) and ".tmp-" not in str(info.value)


# Issue 9 sweep (api/atomic_folder/path=garbage, path=nested_json): the context managers checked their
# path only once a `with` block entered them, so a call with a file for a folder returned quietly.
@pytest.mark.parametrize(
    ("func", "make", "error", "match"),
    [
        ("atomic_folder", lambda d: d / "data.png", NotADirectoryError, "it exists and is not a folder"),
        ("atomic_folder", lambda d: "", ValueError, "path must name a folder; got ''"),
        ("atomic_folder", lambda d: 3, TypeError, "path must be a str or os.PathLike; got int"),
        ("atomic_write", lambda d: d, IsADirectoryError, "it is a directory"),
        ("atomic_write", lambda d: d / "no" / "a.txt", FileNotFoundError, "does not exist"),
        ("atomic_write", lambda d: None, TypeError, "path must be a str or os.PathLike; got NoneType"),
    ],
)
def test_atomic_outputs_check_their_path_when_called(tmp_path, func, make, error, match):
    import vergence.io

    (tmp_path / "data.png").write_bytes(b"garbage")
    with pytest.raises(error, match=match):
        getattr(vergence.io, func)(make(tmp_path))  # no `with`: the call itself refuses
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data.png"]


def test_atomic_folder_merges_subfolders_into_an_existing_folder(tmp_path):
    from vergence.io import atomic_folder

    out = tmp_path / "out"
    (out / "sub").mkdir(parents=True)
    (out / "sub" / "keep.txt").write_text("old")
    (out / "sub" / "a.txt").write_text("old")
    with atomic_folder(out) as tmp:
        (tmp / "sub").mkdir()
        (tmp / "sub" / "a.txt").write_text("new")
        (tmp / "new").mkdir()
        (tmp / "new" / "b.txt").write_text("b")
    assert (out / "sub" / "a.txt").read_text() == "new"
    assert (out / "sub" / "keep.txt").read_text() == "old"
    assert (out / "new" / "b.txt").read_text() == "b"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
