"""Where Numba keeps Vergence's compiled kernels: a folder the user owns, not the installed package.

Numba writes the machine code of a ``cache=True`` kernel beside its source (``__pycache__``) unless
``NUMBA_CACHE_DIR`` names a folder. An installed package may be read-only, or shared by several
users, so the ``vergence`` command (and the test suite) point Numba at the user's cache instead
(:func:`use_numba_cache_dir`), before Numba is imported. Importing Vergence changes nothing: a
program that imports the library chooses for itself.

This module imports only the standard library: the console script calls it before anything heavy.
"""

from __future__ import annotations

import errno
import os
import sys
from collections.abc import Mapping, MutableMapping
from pathlib import Path

__all__ = ["NUMBA_CACHE_ENV", "numba_cache_dir", "use_numba_cache_dir"]

# The variable Numba reads (once, when it is first imported) for its cache folder.
NUMBA_CACHE_ENV = "NUMBA_CACHE_DIR"


def numba_cache_dir(environ: Mapping[str, str] | None = None) -> Path:
    """The folder Numba's cache of Vergence's kernels lives in, by the rule of the ``vergence`` command.

    Parameters
    ----------
    environ : mapping of str to str, optional
        The environment to read (default ``os.environ``).

    Returns
    -------
    Path
        ``$NUMBA_CACHE_DIR`` when the user set it (non-empty); else ``$XDG_CACHE_HOME/vergence/numba``
        when ``XDG_CACHE_HOME`` is an absolute path; else ``~/.cache/vergence/numba``.

    Notes
    -----
    XDG Base Directory Specification 0.8: a relative or empty ``XDG_CACHE_HOME`` is invalid and is
    ignored, the default being ``$HOME/.cache``.

    Examples
    --------
    >>> numba_cache_dir({"XDG_CACHE_HOME": "/var/cache/ada"}).as_posix()
    '/var/cache/ada/vergence/numba'
    >>> numba_cache_dir({"NUMBA_CACHE_DIR": "/tmp/kernels", "XDG_CACHE_HOME": "/var/cache/ada"}).as_posix()
    '/tmp/kernels'
    """
    env = os.environ if environ is None else environ
    if env.get(NUMBA_CACHE_ENV):
        return Path(env[NUMBA_CACHE_ENV])
    xdg = env.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        base = Path(xdg)
    else:
        home = env.get("HOME") or os.path.expanduser("~")
        base = Path(home) / ".cache"
    return base / "vergence" / "numba"


def use_numba_cache_dir(environ: MutableMapping[str, str] | None = None) -> Path | None:
    """Point Numba at :func:`numba_cache_dir` (``NUMBA_CACHE_DIR``), unless the user chose a folder.

    Call it before Numba is imported: Numba reads the variable once. The folder is created; if that
    fails, ``NUMBA_CACHE_DIR`` stays unset (Numba then caches beside the package's sources, or in its
    own user folder where those are read-only) and one ``warning:`` line on stderr says so.

    Parameters
    ----------
    environ : mutable mapping of str to str, optional
        The environment to change (default ``os.environ``).

    Returns
    -------
    Path or None
        The folder Numba will use, or None where Numba's default applies.
    """
    env = os.environ if environ is None else environ
    if env.get(NUMBA_CACHE_ENV):
        return Path(env[NUMBA_CACHE_ENV])
    folder = numba_cache_dir(env)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not os.access(folder, os.W_OK | os.X_OK):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(folder))
    except OSError as exc:
        reason = exc.strerror[:1].lower() + exc.strerror[1:] if exc.strerror else str(exc)
        sys.stderr.write(f"warning: cannot use {folder} for compiled kernels ({reason}); Numba's default "
                         f"cache applies (set {NUMBA_CACHE_ENV} to choose a folder)\n")
        sys.stderr.flush()
        return None
    env[NUMBA_CACHE_ENV] = str(folder)
    return folder
