"""Atomic output: complete files only, usual permissions; JSON input with one error."""

import json
import os
import stat

import pytest

from robust_ismpc.exceptions import ParameterError
from robust_ismpc.io import atomic_write_json, read_json


def test_atomic_json_has_umask_permissions_and_no_leftovers(tmp_path):
    """The written file is complete, readable with the umask's permissions, and no temp file remains."""
    atomic_write_json(tmp_path / "a.json", {"x": 1})
    assert json.loads((tmp_path / "a.json").read_text()) == {"x": 1}
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE((tmp_path / "a.json").stat().st_mode) == 0o666 & ~umask
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_read_json_returns_what_was_written_and_checks_a_required_key(tmp_path):
    atomic_write_json(tmp_path / "a.json", {"cells": [1, 2]})
    assert read_json(tmp_path / "a.json") == {"cells": [1, 2]}
    assert read_json(tmp_path / "a.json", "cells") == {"cells": [1, 2]}
    with pytest.raises(ParameterError, match="has no 'frontiers_n'"):
        read_json(tmp_path / "a.json", "frontiers_n")


@pytest.mark.parametrize("content", [None, "{not json", "[1, 2]"])
def test_read_json_names_the_file_it_cannot_use(tmp_path, content):
    path = tmp_path / "b.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ParameterError, match="b.json"):
        read_json(path, "cells")
