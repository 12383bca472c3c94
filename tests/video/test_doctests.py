"""The examples in the docstrings of vergence.video run and print what they say."""

from __future__ import annotations

import doctest
import importlib

import pytest


@pytest.mark.parametrize("name", ["clips", "cuts", "edges", "layout", "outputs", "reader", "search", "stability", "writer"])
def test_docstring_examples(name):
    module = importlib.import_module(f"vergence.video.{name}")
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
