"""What :func:`vergence.commands.naming` leaves to the commands that read files: a library error about
two arguments at once (``"left and right must both be grey or both colour"``); and, re-exported,
:func:`~vergence.commands._spec.literal` for a file's name inside a template."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from vergence.commands._spec import ParameterError, literal

__all__ = ["literal", "naming_both"]


@contextmanager
def naming_both(words: str, first: str, second: str) -> Iterator[None]:
    """Let a library error that begins with two arguments (``"left and right ..."``) name the two parameters.

    Inside ``with naming_both("left_image and right_image", "left", "right"):`` a ``ValueError`` or
    ``TypeError`` whose message begins with ``words`` becomes a :class:`ParameterError` beginning
    ``{left} and {right}``. A :class:`ParameterError` and any other error pass unchanged. Put it inside
    :func:`~vergence.commands.naming`, which would otherwise name the first argument alone.
    """
    try:
        yield
    except ParameterError:
        raise
    except (ValueError, TypeError) as exc:
        message = str(exc)
        if message.startswith(words + " "):
            raise ParameterError("{" + first + "} and {" + second + "}" + literal(message[len(words):])) from exc
        raise
