"""The ``backend`` fixture: every conformance test runs once per backend under test.

The backends under test are those chosen with ``--neurovpr-backend`` or
``NEUROVPR_BACKENDS`` (:mod:`.plugin`), else every declared one. Backends that are
declared but cannot run here (simulator not installed, mapping-only targets) still
appear as parameters and skip with the registry's reason, so the report lists them.
Inside a test, :meth:`Target.compile` skips with an explicit reason when the backend's
capabilities lack a feature of the network or list the case as unsupported.
"""

from __future__ import annotations

import pytest

from neurovpr.runtime.registry import BackendInfo

from .plugin import selected_backends
from .target import Target, declared, describe


def backends_under_test(config: pytest.Config) -> dict[str, BackendInfo]:
    """The declared backends the session runs on (every one unless some are selected); only those are loaded.

    The plugin has already refused selected names that no entry point declares.
    """
    names = selected_backends(config) or declared()
    return {name: describe(name) for name in names}


def _param(info: BackendInfo) -> object:
    reason = None
    if not info.available or info.backend is None:
        reason = f"backend {info.name!r} is not available: {info.reason}"
    elif not info.backend.capabilities.runs:
        refusal = info.backend.capabilities.run_refusal or "it maps networks but does not run them"
        reason = f"backend {info.name!r} does not run simulations: {refusal}"
    marks = [pytest.mark.skip(reason=reason)] if reason else []
    return pytest.param(info.name, id=info.name, marks=marks)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Parametrise every test that asks for ``backend`` (or ``declared``) over the backends under test."""
    infos = backends_under_test(metafunc.config)
    if "backend" in metafunc.fixturenames:
        metafunc.parametrize("backend", [_param(info) for info in infos.values()], indirect=True, scope="session")
    if "declared" in metafunc.fixturenames:
        usable = [pytest.param(info, id=name) for name, info in infos.items() if info.backend is not None]
        metafunc.parametrize("declared", usable)


@pytest.fixture(scope="session")
def backend(request: pytest.FixtureRequest) -> Target:
    """The backend under test."""
    info = describe(request.param)
    assert info.backend is not None
    return Target(info.name, info.backend)
