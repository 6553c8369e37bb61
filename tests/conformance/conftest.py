"""The ``backend`` fixture: every conformance test runs once per declared backend.

Backends that are declared but cannot run here (simulator not installed,
mapping-only targets) still appear as parameters and skip with the registry's
reason, so the report lists them. Inside a test, :meth:`Target.compile` skips
with an explicit reason when the backend's capabilities lack a feature of the
network or list the case as unsupported.
"""

from __future__ import annotations

import os

import pytest

from neurovpr.runtime.registry import BackendInfo

from .target import Target, declared_backends

_SELECT_ENV = "NEUROVPR_BACKENDS"


def _selected() -> set[str] | None:
    names = {s.strip() for s in os.environ.get(_SELECT_ENV, "").split(",") if s.strip()}
    return names or None


def _param(info: BackendInfo, selected: set[str] | None) -> object:
    reason = None
    if selected is not None and info.name not in selected:
        reason = f"backend {info.name!r} not selected by {_SELECT_ENV}"
    elif not info.available or info.backend is None:
        reason = f"backend {info.name!r} is not available: {info.reason}"
    elif not info.backend.capabilities.runs:
        refusal = info.backend.capabilities.run_refusal or "it maps networks but does not run them"
        reason = f"backend {info.name!r} does not run simulations: {refusal}"
    marks = [pytest.mark.skip(reason=reason)] if reason else []
    return pytest.param(info.name, id=info.name, marks=marks)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Parametrise every test that asks for ``backend`` over all declared backends."""
    if "backend" in metafunc.fixturenames:
        selected = _selected()
        params = [_param(info, selected) for info in declared_backends().values()]
        metafunc.parametrize("backend", params, indirect=True, scope="session")


@pytest.fixture(scope="session")
def backend(request: pytest.FixtureRequest) -> Target:
    """The backend under test."""
    info = declared_backends()[request.param]
    assert info.backend is not None
    return Target(info.name, info.backend)
