"""``vergence rectify --image-list`` with a camera file that names its images (issue 9 sweep kin).

The image list was dropped unseen for any format but Bundler; it is refused in one line naming the
option, exit code 2, and nothing is written.
"""

from __future__ import annotations

from vergence.cli import main


def test_image_list_with_a_middlebury_file_is_refused(capsys, shared_data, tmp_path):
    dino = shared_data / "collections" / "dino"
    (tmp_path / "list.txt").write_text("dino0002.png\ndino0001.png\n")
    code = main(["rectify", str(dino / "dino0002.png"), str(dino / "dino0001.png"), "--cameras",
                 str(dino / "dino_par.txt"), "--image-list", str(tmp_path / "list.txt"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0
    assert err == "error: --image-list applies to Bundler cameras (*.out) only; dino_par.txt is a middlebury camera file"
    assert not (tmp_path / "o").exists()
