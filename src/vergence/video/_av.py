"""PyAV, imported on first use: the ``video`` extra (``pip install 'vergence[video]'``).

Why PyAV and not imageio-ffmpeg (measured on PyAV 18.1, manylinux wheel):

- The wheel bundles FFmpeg's libraries (libavcodec 62 with libx264, 104 MB installed); imageio-ffmpeg
  bundles an ``ffmpeg`` executable of similar size. Both install from PyPI alone.
- PyAV decodes and encodes in the process, frame by frame, as numpy arrays: the number of frames, the
  frame rate and a decoding error come from FFmpeg's own structures (a truncated file is reported
  at the frame where it stops), where imageio-ffmpeg parses the text ``ffmpeg`` prints on a pipe.
- Audio is copied packet by packet into the output container (no re-encoding, no second ``ffmpeg``
  run), and any pixel format FFmpeg knows (``yuv420p``, ``yuv444p`` for anaglyph) is one argument.
"""

from __future__ import annotations

from types import ModuleType

__all__ = ["require_av"]


def require_av() -> ModuleType:
    """The ``av`` module, or an ImportError that names the extra to install."""
    try:
        import av
    except ImportError as exc:
        raise ImportError("reading and writing video needs PyAV: install the video extra, "
                          "pip install 'vergence[video]'") from exc
    av.logging.set_level(av.logging.PANIC)  # FFmpeg's own messages would bypass our one-line errors
    return av
