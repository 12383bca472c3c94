"""The rendered test clips (tabletop, cut, stadium), made once per session in a temporary folder."""

from __future__ import annotations

import pytest

pytest.importorskip("av", reason="the video extra is not installed: pip install 'vergence[video]'")

# Frames per shot of the session's clips: two shots, 24 frames in all, 160x90 per view (about 6 s to
# render and encode on 2 cores).
FRAMES_PER_SHOT = 12


@pytest.fixture(scope="session")
def clips(tmp_path_factory):
    from vergence.video import make_test_clips

    return make_test_clips(tmp_path_factory.mktemp("clips"), frames_per_shot=FRAMES_PER_SHOT)


@pytest.fixture(scope="session")
def truth(clips):
    import numpy as np

    with np.load(clips.truth) as data:
        return {k: data[k] for k in data.files}
