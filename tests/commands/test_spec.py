"""The command table itself (vergence.commands._spec): refusals spelled per face, the checks every
command's run makes before its work, hooks, and the one JSON text both faces print."""

from __future__ import annotations

import math

import pytest

from vergence.commands import MAX_LIST_ITEMS, Command, Parameter, ParameterError, naming, to_json


def _command(calls: list) -> Command:
    def work(**values):
        calls.append(values)
        return values

    return Command("fake", "Do nothing.", (
        Parameter("level", "integer", "A level, like {depth}."),
        Parameter("depth", "numbers", "Depths.", None),
        Parameter("name", "text", "A name.", None),
        Parameter("image", "file", "An image.", None, option=""),
        Parameter("fast", "flag", "Fast.", False, option="--quick"),
    ), work, hooks=("progress",))


def test_a_refusal_is_spelled_by_each_face():
    exc = ParameterError("{far} must be > {near} 90; got {{80}}")
    assert str(exc) == "far must be > near 90; got {80}"
    assert exc.spelled(lambda n: "--" + n) == "--far must be > --near 90; got {80}"


def test_naming_renames_the_leading_argument_only():
    with pytest.raises(ParameterError) as info, naming(distance="viewing_distance"):
        raise ValueError("distance must be > 0; got {-1}")
    assert info.value.template == "{viewing_distance} must be > 0; got {{-1}}"
    with pytest.raises(ValueError, match="^distances must") as plain, naming(distance="viewing_distance"):
        raise ValueError("distances must be sorted")  # another word: left as it is
    assert not isinstance(plain.value, ParameterError)


def test_run_checks_before_the_work():
    calls: list = []
    command = _command(calls)
    assert command.cli_names == {"level": "--level", "depth": "--depth", "name": "--name", "image": "IMAGE",
                                 "fast": "--quick"}
    for values, message in [
        ({}, "missing level"),
        ({"level": 1, "colour": 2}, "unknown parameter 'colour'; valid: level, depth, name, image, fast"),
        ({"level": 1, "name": ""}, "name: must not be empty"),
        ({"level": 1, "depth": [1.0] * (MAX_LIST_ITEMS + 1)},
         f"depth takes at most {MAX_LIST_ITEMS} values (MAX_LIST_ITEMS); got {MAX_LIST_ITEMS + 1}"),
    ]:
        with pytest.raises(ParameterError) as info:
            command.run(**values)
        assert str(info.value) == message
    assert calls == []
    seen = []
    result = command.run(level=2, depth=(1.0, 2.0), progress=seen.append)
    assert result == {"level": 2, "depth": [1.0, 2.0], "name": None, "image": None, "fast": False,
                      "progress": seen.append}
    assert len(calls) == 1


def test_to_json_is_the_printed_text_and_refuses_infinity():
    assert to_json({"a": [1, 2.5]}) == '{\n  "a": [\n    1,\n    2.5\n  ]\n}\n'
    with pytest.raises(ValueError):
        to_json({"a": math.inf})
