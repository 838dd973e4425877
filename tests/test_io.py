"""Atomic output: complete files only, usual permissions."""

import json
import os
import stat

from robust_ismpc.io import atomic_write_json


def test_atomic_json_has_umask_permissions_and_no_leftovers(tmp_path):
    """The written file is complete, readable with the umask's permissions, and no temp file remains."""
    atomic_write_json(tmp_path / "a.json", {"x": 1})
    assert json.loads((tmp_path / "a.json").read_text()) == {"x": 1}
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE((tmp_path / "a.json").stat().st_mode) == 0o666 & ~umask
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]
