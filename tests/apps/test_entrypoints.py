"""One loader for every kind of plugin: unknown, broken or mistyped entry points are one sentence, in the caller's error type."""

from __future__ import annotations

import importlib.metadata

import pytest

from neurovpr import entrypoints
from neurovpr.apps.modelapi import ModelPlugin, get_model
from neurovpr.errors import BackendUnavailableError, ValidationError
from neurovpr.hardware.architectures import get_architecture
from neurovpr.runtime.backend import Backend
from neurovpr.runtime.registry import get_backend

GROUP = "neurovpr.test-plugins"


@pytest.fixture
def plugins(monkeypatch: pytest.MonkeyPatch) -> None:
    """Real entry points (to an importable object, a missing module, a duplicate name) in a group of their own."""
    points = [
        importlib.metadata.EntryPoint("wrong", "json:dumps", GROUP),
        importlib.metadata.EntryPoint("missing", "neurovpr_no_such_module:thing", GROUP),
        importlib.metadata.EntryPoint("reference", "neurovpr.backends.reference:BACKEND", GROUP),
        importlib.metadata.EntryPoint("reference", "json:loads", GROUP),
    ]
    real = importlib.metadata.entry_points
    monkeypatch.setattr(
        entrypoints.importlib.metadata,
        "entry_points",
        lambda group: [ep for ep in points if ep.group == group] if group == GROUP else real(group=group),
    )


def _load(name: str) -> object:
    return entrypoints.load_declared(GROUP, name, Backend, what="widget", unknown=ValidationError, broken=BackendUnavailableError)


def test_load_declared(plugins: None) -> None:
    assert entrypoints.declared_names(GROUP) == ["missing", "reference", "wrong"]
    assert isinstance(_load("reference"), Backend)  # the first of a duplicated name
    with pytest.raises(ValidationError, match=r"^Unknown widget 'nope'; known widgets: missing, reference, wrong\.$"):
        _load("nope")
    with pytest.raises(BackendUnavailableError, match=r"^Widget 'missing' failed to load: ModuleNotFoundError"):
        _load("missing")
    with pytest.raises(BackendUnavailableError, match=r"^Widget 'wrong' \(entry point json:dumps\) is a function, not a"):
        _load("wrong")


def test_callers_keep_their_error_types() -> None:
    with pytest.raises(BackendUnavailableError, match=r"Unknown backend 'nope'; known backends: .*reference"):
        get_backend("nope")
    with pytest.raises(BackendUnavailableError, match="must be a string"):
        get_backend(3)  # type: ignore[arg-type]
    with pytest.raises(ValidationError, match=r"Unknown model 'nope'; known models: .*modular"):
        get_model("nope")
    with pytest.raises(ValidationError, match=r"Unknown architecture 'nope'; known architectures: .*loihi"):
        get_architecture("nope")
    assert isinstance(get_model("mbsnn"), ModelPlugin) and isinstance(get_backend("reference"), Backend)
