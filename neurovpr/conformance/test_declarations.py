"""Backends' declarations about the suite are well formed (runs without any simulator)."""

from __future__ import annotations

import dataclasses
from types import MappingProxyType

import pytest

import neurovpr as nv
from neurovpr.runtime.backend import Backend, Capabilities, ToleranceOverride
from neurovpr.runtime.registry import BackendInfo

from .cases import CASES
from .target import Target
from .tolerances import DEFAULT, Tolerances


def test_unsupported_cases_are_known_and_explained(declared: BackendInfo):
    """Every case a backend lists as unsupported exists and comes with a reason."""
    assert declared.backend is not None
    for case, reason in declared.backend.capabilities.unsupported.items():
        assert case in CASES, f"backend {declared.name!r} lists unknown conformance case {case!r}"
        assert isinstance(reason, str) and reason.strip(), f"backend {declared.name!r} gives no reason for {case!r}"


def test_tolerance_overrides_are_explained_and_only_loosen(declared: BackendInfo):
    """Every tolerance override a backend declares names a known case and bound, gives a
    reason, and only loosens a default bound."""
    assert declared.backend is not None
    name = declared.name
    fields = {f.name for f in dataclasses.fields(Tolerances)}
    for case, override in declared.backend.capabilities.tolerances.items():
        assert isinstance(override, ToleranceOverride), f"tolerance override {name!r}/{case!r} is not a ToleranceOverride"
        assert case in CASES, f"tolerance override {name!r}: unknown case {case!r}"
        assert override.reason.strip(), f"tolerance override {name!r}/{case!r} gives no reason"
        for key, value in override.changes.items():
            assert key in fields, f"tolerance override {name!r}/{case!r}: unknown bound {key!r}"
            assert value >= getattr(DEFAULT, key), f"override {name!r}/{case!r} tightens {key!r}"


class _Limited(Backend):
    """A declaration only (never compiled): no conductance-based cells, no Poisson case."""

    name = "limited"
    capabilities = Capabilities(
        cell_types=frozenset({"IF_curr_exp", "SpikeSourceArray"}),
        connectors=frozenset({"AllToAllConnector"}),
        synapses=frozenset({"StaticSynapse"}),
        learns=False,
        heterogeneous_delays=False,
        unsupported=MappingProxyType({"poisson": "its random numbers come from the chip"}),
    )


def test_missing_features_skip_with_their_reason():
    """A case the backend lists, or a feature it lacks, skips naming the reason (never silently)."""
    target = Target("limited", _Limited())
    with pytest.raises(pytest.skip.Exception, match="case 'poisson' unsupported: its random numbers come from the chip"):
        target.require("poisson")
    net = nv.Network("needs")
    net.add_population("src", 1, nv.SpikeSourceArray.from_lists([[1.0]]))
    net.add_population("cond", 1, nv.IF_cond_exp())
    net.connect("src", "cond", nv.OneToOneConnector(), nv.STDPMechanism(weight=0.1))
    with pytest.raises(pytest.skip.Exception) as info:
        target.require("psp_cond", net, recordables=("gsyn_exc",), heterogeneous_delays=True)
    message = str(info.value)
    for part in ("IF_cond_exp", "OneToOneConnector", "STDPMechanism", "on-line learning", "'gsyn_exc'",
                 "heterogeneous delays", "psp_cond"):
        assert part in message, message
    target.require("psp_curr")  # nothing missing: no skip
