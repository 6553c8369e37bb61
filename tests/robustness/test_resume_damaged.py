"""--resume verifies every finished part and trains damaged ones again, naming them; the result is bit-identical."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import pytest

from neurovpr.apps.rundir import damaged_part
from neurovpr.fileio import is_temp_name

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "models"))
from modular_tiny import TINY, tiny_images

from neurovpr.models.modular_snn.runs import train_run


def _files(run: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((run / "modules").iterdir())}


@pytest.mark.parametrize("damage", ["truncate_h5", "flip_npz", "empty_npz"])
def test_resume_redoes_a_damaged_module(tmp_path: Path, damage: str, capsys: pytest.CaptureFixture[str]) -> None:
    ref = tiny_images(4, seed=1)
    kw = {"members": 1, "seed": 5, "workers": 1, "progress": False}
    train_run(tmp_path / "full", ref, TINY, **kw)
    expected = _files(tmp_path / "full")
    part = train_run(tmp_path / "part", ref, TINY, **kw)
    assert part["complete"]
    modules = tmp_path / "part" / "modules"
    first = sorted(modules.glob("*.h5"))[0]
    target = first if damage == "truncate_h5" else first.with_suffix(".npz")
    data = target.read_bytes()
    if damage == "truncate_h5":
        target.write_bytes(data[: len(data) // 2])
    elif damage == "flip_npz":
        middle = len(data) // 3
        target.write_bytes(data[:middle] + bytes([data[middle] ^ 0xFF]) + data[middle + 1 :])
    else:
        target.write_bytes(b"")
    assert damaged_part(target) is not None
    (modules / f".{first.name}.999999999.0123456789ab.tmp").write_bytes(b"partial")  # a killed writer's leftover
    capsys.readouterr()
    rest = train_run(tmp_path / "part", ref, TINY, resume=True, **kw)
    err = capsys.readouterr().err
    assert rest["complete"] and rest["trained_now"] == 1, rest
    assert f"{target} is damaged" in err and f"module {first.stem} is trained again" in err
    got = _files(tmp_path / "part")
    assert sorted(got) == sorted(expected)
    for name in expected:  # networks bit for bit; records array by array, their timings aside
        if name.endswith(".h5"):
            assert got[name] == expected[name], name
        else:
            a, b = (np.load(io.BytesIO(x), allow_pickle=False) for x in (got[name], expected[name]))
            for key in a.files:
                if "time" not in key and "second" not in key:
                    np.testing.assert_array_equal(a[key], b[key], err_msg=f"{name}: {key}")
    assert not [p for p in (tmp_path / "part").rglob("*") if is_temp_name(p.name)]
