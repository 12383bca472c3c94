"""The server's work slots: the computations a request waits for (a twin, a StereoSpace move or pair,
a rig plan) run on worker threads, at most :data:`MAX_CALLS` at once; one more is refused at once
(429), never queued behind the others. Jobs have their own queue (:mod:`vergence.web.jobs`)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

from starlette.concurrency import run_in_threadpool

__all__ = ["MAX_CALLS", "Busy", "run_in_slot", "work_slot"]

#: Computations running at once for requests. One holds a worker thread and one or two cores (Numba's
#: and OpenCV's threads) for up to seconds: four keep a 2-core machine busy without letting a burst of
#: requests pile up behind each other.
MAX_CALLS = 4

_T = TypeVar("_T")


class Busy(Exception):
    """:data:`MAX_CALLS` computations are running: the request is answered 429."""

    status = 429

    def __init__(self) -> None:
        self.message = f"the server is busy: {MAX_CALLS} calls are running (MAX_CALLS); try again in a moment"
        super().__init__(self.message)


_SLOTS = threading.BoundedSemaphore(MAX_CALLS)


@contextmanager
def work_slot() -> Iterator[None]:
    """Hold one of the :data:`MAX_CALLS` slots for the block.

    Raises
    ------
    Busy
        At once, when every slot is held.
    """
    if not _SLOTS.acquire(blocking=False):
        raise Busy()
    try:
        yield
    finally:
        _SLOTS.release()


async def run_in_slot(work: Callable[..., _T], *args: Any) -> _T:
    """``work(*args)`` on a worker thread, off the event loop, in a slot (:func:`work_slot`)."""
    with work_slot():
        return await run_in_threadpool(work, *args)
