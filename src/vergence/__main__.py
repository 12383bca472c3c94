"""``python -m vergence``: the ``vergence`` command (:func:`vergence.cli._entry`)."""

from vergence.cli import _entry

if __name__ == "__main__":
    _entry()
