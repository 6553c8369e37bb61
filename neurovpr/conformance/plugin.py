"""neurovpr's pytest plugin: the option that picks the backends the conformance suite runs on.

Registered through the ``pytest11`` entry point, so it loads in every pytest session of
an environment with neurovpr; it adds one command-line option and, when backends are
selected (by the option or ``NEUROVPR_BACKENDS``), refuses names no
``neurovpr.backends`` entry point declares. The suite itself
(``pytest --pyargs neurovpr.conformance``) reads the selection in its ``conftest.py``.
"""

from __future__ import annotations

import os

import pytest

from neurovpr.runtime.registry import declared_names

__all__ = ["OPTION", "ENVIRONMENT", "selected_backends"]

#: The command-line option (``--neurovpr-backend NAME``, repeatable, comma lists allowed).
OPTION = "--neurovpr-backend"
#: The environment variable selecting backends the same way (``NAME1,NAME2``).
ENVIRONMENT = "NEUROVPR_BACKENDS"


def pytest_addoption(parser: pytest.Parser) -> None:
    """Add ``--neurovpr-backend``."""
    group = parser.getgroup("neurovpr", "neurovpr backend conformance suite")
    group.addoption(
        OPTION,
        action="append",
        default=[],
        metavar="NAME",
        dest="neurovpr_backend",
        help=f"run neurovpr.conformance on this backend (an entry point of neurovpr.backends); repeat or "
        f"separate names by commas; default: ${ENVIRONMENT}, else every declared backend",
    )


def selected_backends(config: pytest.Config) -> tuple[str, ...] | None:
    """The backend names chosen on the command line or in ``NEUROVPR_BACKENDS``; ``None`` for all."""
    given = list(config.getoption("neurovpr_backend", default=None) or [])
    if not given:
        given = [os.environ.get(ENVIRONMENT, "")]
    names = tuple(dict.fromkeys(n.strip() for item in given for n in item.split(",") if n.strip()))
    return names or None


def pytest_configure(config: pytest.Config) -> None:
    """Refuse a selected backend that no entry point declares (before anything is collected)."""
    selected = selected_backends(config)
    if selected is None:
        return
    declared = declared_names()
    unknown = [name for name in selected if name not in declared]
    if unknown:
        raise pytest.UsageError(
            f"{OPTION}: backend {unknown[0]!r} is not declared by any neurovpr.backends entry point "
            f"(declared: {', '.join(declared) or 'none'})."
        )
