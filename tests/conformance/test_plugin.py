"""The conformance suite as a third-party backend package runs it: ``pytest --pyargs neurovpr.conformance``.

A temporary site folder holds ``outoftree_backend.py`` and a ``.dist-info`` folder declaring
its backends in the ``neurovpr.backends`` entry point group, as an installed wheel would;
pytest runs in a fresh process from an empty folder (none of this repository's pytest
settings apply) with that folder on ``PYTHONPATH``.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
MODULE = "outoftree_backend"


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding the out-of-tree backend package and its distribution metadata."""
    root = tmp_path_factory.mktemp("site")
    shutil.copy(HERE / f"{MODULE}.py", root / f"{MODULE}.py")
    info = root / "outoftree_backend-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: outoftree-backend\nVersion: 0.1\n", encoding="utf-8")
    (info / "entry_points.txt").write_text(
        f"[neurovpr.backends]\nwrapped-reference = {MODULE}:WRAPPED\nbiased-reference = {MODULE}:BIASED\n",
        encoding="utf-8",
    )
    return root


def _pytest(site: Path, run_in: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep))
    env.pop("NEUROVPR_BACKENDS", None)
    command = [sys.executable, "-m", "pytest", "--pyargs", "neurovpr.conformance", "-p", "no:cacheprovider",
               "-p", "no:nengo", "-rA", *args]  # fmt: skip
    return subprocess.run(command, cwd=run_in, env=env, capture_output=True, text=True, timeout=900, check=False)


def _outcomes(stdout: str) -> dict[str, list[str]]:
    """Test ids by outcome from the ``-rA`` summary (``PASSED id``, ``SKIPPED [1] file:line: reason``)."""
    found: dict[str, list[str]] = {}
    for line in stdout.splitlines():
        match = re.match(r"^(PASSED|FAILED|ERROR|SKIPPED) (.*)$", line)
        if match:
            found.setdefault(match.group(1), []).append(match.group(2))
    return found


def test_out_of_tree_backend_runs_the_shipped_suite(site, tmp_path):
    """The suite runs only on the selected entry point, skips what it declares it cannot do with the reason,
    and passes everything else."""
    result = _pytest(site, tmp_path, "--neurovpr-backend", "wrapped-reference")
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    outcomes = _outcomes(result.stdout)
    assert len(outcomes.get("PASSED", [])) >= 30
    parametrised = [test_id for test_id in outcomes["PASSED"] if "[" in test_id]
    assert len(parametrised) >= 30 and all("wrapped-reference" in test_id for test_id in parametrised)
    skipped = "\n".join(outcomes.get("SKIPPED", []))
    assert "declares case 'poisson' unsupported: its random numbers come from the host of this package" in skipped
    assert "declares no support for: synapse DiehlCookSTDP (projection 'plastic'): this package leaves" in skipped
    assert "FAILED" not in outcomes and "ERROR" not in outcomes


def test_declared_tolerances_apply_per_case(site, tmp_path):
    """Traces recorded 1e-6 mV high pass the case whose bound the backend loosened and fail the other."""
    result = _pytest(site, tmp_path, "--neurovpr-backend", "biased-reference", "-k", "constant_current_spike_times")
    assert result.returncode == 1, result.stdout[-4000:]
    outcomes = _outcomes(result.stdout)
    assert [t for t in outcomes.get("PASSED", []) if "lif_rate_curr" in t] and not outcomes.get("SKIPPED")
    assert len(outcomes["FAILED"]) == 1 and "lif_rate_cond" in outcomes["FAILED"][0]
    assert "membrane, i_offset=" in result.stdout  # it failed on the trace bound


def test_several_backends_and_unknown_names(site, tmp_path):
    """A comma list selects several backends (and only those); a name no entry point declares is a usage error."""
    env_run = _pytest(site, tmp_path, "-k", "declarations", "--neurovpr-backend", "wrapped-reference,biased-reference")
    assert env_run.returncode == 0, env_run.stdout[-3000:]
    ids = _outcomes(env_run.stdout)["PASSED"]
    assert any("[wrapped-reference]" in t for t in ids) and any("[biased-reference]" in t for t in ids)
    assert not any("[reference]" in t for t in ids)
    bad = _pytest(site, tmp_path, "--neurovpr-backend", "no-such-backend")
    assert bad.returncode == 4
    assert "--neurovpr-backend: backend 'no-such-backend' is not declared" in bad.stderr
    assert "wrapped-reference" in bad.stderr and "reference" in bad.stderr
