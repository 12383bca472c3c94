"""The workbench's kernels, compiled in the background when the server starts (``vergence serve``).

The first request of a page would otherwise wait for Numba to compile its kernels (issue 29: the
first ``/api/compare`` 24.5 s, then 0.08 s). :class:`KernelWarmup` runs the warm-up groups of the
pages (:data:`PAGE_GROUPS`, :func:`vergence.warm.warm`) one by one in a daemon thread and reports
its state in ``GET /api/health`` (``"kernels"``), which the page shows as a banner until it is
``ready``. A request that comes first is served at once: it compiles what it needs (Numba holds one
lock for every compilation, so the two never compile the same kernel twice at once).
"""

from __future__ import annotations

import logging
import threading
from typing import Any

__all__ = ["KERNEL_STATES", "PAGE_GROUPS", "KernelWarmup"]

#: The warm-up groups (:data:`vergence.warm.WARM_GROUPS`) of the workbench's pages, in the order run:
#: pages 2 (synthesize, render, match, compare), 5 (specular), 3 (stereospace) and 4 (rig).
PAGE_GROUPS = ("synthesize", "render", "compare", "match", "specular", "stereospace", "rig")

#: The states of ``/api/health``'s ``"kernels"``: not started (the server was made without the
#: warm-up), running, all groups done, or done with at least one group failed.
KERNEL_STATES = ("cold", "warming", "ready", "failed")

_log = logging.getLogger("vergence.web")


class KernelWarmup:
    """The background warm-up of ``groups`` and its state (thread-safe).

    Parameters
    ----------
    groups : tuple of str, optional
        Names of :data:`vergence.warm.WARM_GROUPS`, run in this order (default :data:`PAGE_GROUPS`).
    """

    def __init__(self, groups: tuple[str, ...] | None = None) -> None:
        self.groups = tuple(PAGE_GROUPS if groups is None else groups)
        self._lock = threading.Lock()
        self._state = "cold"
        self._done = 0
        self._error: str | None = None
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Start the warm-up in a daemon thread (once: a second call does nothing)."""
        with self._lock:
            if self._thread is not None:
                return
            self._state = "warming"
            self._thread = threading.Thread(target=self._run, name="vergence-kernel-warmup", daemon=True)
        self._thread.start()

    def status(self) -> dict[str, Any]:
        """``{"state": one of KERNEL_STATES, "done": groups done, "total": groups}``, and ``"error"``
        (one line naming the group) when the state is ``failed``."""
        with self._lock:
            status: dict[str, Any] = {"state": self._state, "done": self._done, "total": len(self.groups)}
            if self._error is not None:
                status["error"] = self._error
            return status

    def join(self, timeout: float | None = None) -> None:
        """Wait for the warm-up's thread (tests; a server never waits for it)."""
        if self._thread is not None:
            self._thread.join(timeout)

    def _run(self) -> None:
        from vergence.warm import warm

        for name in self.groups:
            try:
                warm([name])
            except Exception as exc:  # noqa: BLE001 - reported in /api/health; the pages compile on demand
                message = f"warm-up group {name}: {type(exc).__name__}: {' '.join(str(exc).split())}"
                _log.warning("%s", message)
                with self._lock:
                    self._error = self._error or message
            with self._lock:
                self._done += 1
        with self._lock:
            self._state = "failed" if self._error is not None else "ready"
