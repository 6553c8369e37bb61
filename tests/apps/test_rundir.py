"""RunDir owns a run folder's layout: names, checked reading, atomic writing, refusal of paths outside it."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

import neurovpr as nv
from neurovpr.apps.rundir import NETWORK_FILE, RUN_FILE, RunDir
from neurovpr.errors import FileFormatError, ValidationError

ROOT = Path(__file__).resolve().parents[2]


def _net() -> nv.Network:
    net = nv.Network("tiny")
    net.add_population("src", 3, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("out", 2, nv.IF_curr_exp())
    net.connect("src", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.5))
    return net


def test_layout_and_round_trip(tmp_path: Path) -> None:
    run = RunDir(str(tmp_path / "run"))
    assert run.network_file == tmp_path / "run" / NETWORK_FILE and run.info_file == tmp_path / "run" / RUN_FILE
    assert not run.finished and not run.has_network
    run.save_network(_net())
    assert run.has_network and not run.finished and run.damaged(NETWORK_FILE) is None
    assert run.load_network().populations["out"].size == 2
    run.write_info({"model": "m", "seed": 3})
    assert run.finished and run.read_info() == {"model": "m", "seed": 3}
    assert [p.name for p in run.path.iterdir() if p.name.endswith(".tmp")] == []
    run.mark_unfinished()
    assert not run.finished and run.has_network
    assert run.part("modules/m0.npz") == run.path / "modules" / "m0.npz"


@pytest.mark.parametrize("name", ["", "../x", "/etc/passwd", "a/../../b", "a\\b"])
def test_parts_stay_inside(tmp_path: Path, name: str) -> None:
    with pytest.raises(ValidationError, match="relative path inside the run directory"):
        RunDir(tmp_path).part(name)


def test_one_sentence_errors(tmp_path: Path) -> None:
    with pytest.raises(ValidationError, match="does not exist"):
        RunDir(tmp_path / "none").load_network()
    with pytest.raises(ValidationError, match=f"has no {NETWORK_FILE}"):
        RunDir(tmp_path).load_network()
    with pytest.raises(ValidationError, match=f"has no {RUN_FILE}"):
        RunDir(tmp_path).read_info()
    (tmp_path / RUN_FILE).write_text("{not json")
    with pytest.raises(ValidationError, match="not readable JSON"):
        RunDir(tmp_path).read_info()
    (tmp_path / RUN_FILE).write_text(json.dumps({"seed": 1}))
    with pytest.raises(ValidationError, match="does not name its model"):
        RunDir(tmp_path).read_info()
    (tmp_path / NETWORK_FILE).write_bytes(b"\x89HDF\r\n\x1a\n broken")
    with pytest.raises(FileFormatError):
        RunDir(tmp_path).load_network()
    assert RunDir(tmp_path).damaged(NETWORK_FILE) is not None
    with pytest.raises(ValidationError, match="must be a path"):
        RunDir(3)  # type: ignore[arg-type]


def test_only_rundir_spells_the_file_names() -> None:
    """No code outside neurovpr/apps/rundir.py writes the run directory's file names as literals."""
    files = subprocess.run(["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    offenders = []
    for name in files:
        if name.startswith("tests/") or name == "neurovpr/apps/rundir.py":
            continue
        for number, line in enumerate((ROOT / name).read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            if any(f'"{lit}"' in code or f"'{lit}'" in code for lit in (NETWORK_FILE, RUN_FILE)):
                offenders.append(f"{name}:{number}: {line.strip()}")
    assert offenders == []
