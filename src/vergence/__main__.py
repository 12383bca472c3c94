"""``python -m vergence``: the ``vergence`` command (:func:`vergence.cli.entry`)."""

from vergence.cli import entry

if __name__ == "__main__":
    entry()
