"""Property tests of the IR constructors and the resource estimator: bad values are refused at construction."""

from __future__ import annotations

import dataclasses
import math
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import neurovpr as nv
from neurovpr.ir.cells import CELL_TYPES
from neurovpr.ir.node import UnknownParameterError
from neurovpr.resources import ResourceLimitError

_NEURONS = [cls for name, cls in sorted(CELL_TYPES.items()) if not cls.is_source and dataclasses.is_dataclass(cls)]
_NUMERIC = [(cls, f) for cls in [*_NEURONS, nv.SpikeSourcePoisson] for f in dataclasses.fields(cls) if f.metadata.get("numeric")]


@settings(max_examples=60, deadline=None)
@given(
    case=st.sampled_from(_NUMERIC),
    value=st.sampled_from([math.nan, -math.inf, math.inf]),
    as_array=st.booleans(),
)
def test_non_finite_parameters_are_refused_unless_documented(case, value, as_array) -> None:
    cls, field = case
    given_value = [1.0, value] if as_array and field.metadata["array"] else value
    if value == math.inf and field.metadata["infinite"]:
        cls(**{field.name: given_value})  # documented meaning (v_thresh: never fires, duration: for ever)
        return
    with pytest.raises(nv.ValidationError, match=rf"{cls.__name__}\.{field.name} must be"):
        cls(**{field.name: given_value})


def test_no_leak_has_its_own_spelling() -> None:
    with pytest.raises(
        nv.ValidationError, match=r"tau_m must be a finite number, got inf \(for a membrane without leak write tau_m=nv.NO_LEAK\)"
    ):
        nv.IF_curr_exp(tau_m=math.inf)
    net = nv.Network("no_leak")
    net.add_population("a", 1, nv.IF_curr_exp(tau_m=nv.NO_LEAK, i_offset=0.0, v_rest=-60.0, v_thresh=0.0))
    sim = nv.compile(net, seed=1)
    sim.record("a", "v")
    sim.run(5.0)
    _, v = sim.trace("a", "v")
    assert all(math.isfinite(x) for x in v.ravel()) and abs(float(v.ravel()[-1]) + 60.0) < 1e-9


@settings(max_examples=40, deadline=None)
@given(
    cls=st.sampled_from([*_NEURONS, nv.SpikeSourcePoisson, nv.StaticSynapse]),
    name=st.text("abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=12),
)
def test_unknown_keywords_name_the_accepted_ones(cls, name) -> None:
    accepted = {f.name for f in dataclasses.fields(cls)}
    if name in accepted:
        return
    with pytest.raises(UnknownParameterError, match=rf"{cls.__name__} has no parameter {name!r}; its parameters are "):
        cls(**{name: 1.0})
    with pytest.raises(TypeError):  # still a TypeError, as for any Python call
        cls(**{name: 1.0})


def _timed(call, pattern: str) -> None:
    start = time.perf_counter()
    with pytest.raises(ResourceLimitError, match=pattern):
        call()
    assert time.perf_counter() - start < 5.0


def test_compile_and_run_estimate_before_allocating(monkeypatch: pytest.MonkeyPatch) -> None:
    big = nv.Network("big")
    big.add_population("a", 10**12, nv.IF_curr_exp())
    _timed(
        lambda: nv.compile(big),
        r"compile: network 'big' needs about .* TiB of memory "
        r"\(most of it for population 'a' \(1000000000000 neurons\)\); the limit is",
    )
    slow = nv.Network("slow")
    slow.add_population("s", 2, nv.SpikeSourcePoisson(rate=5.0))
    slow.add_population("a", 2, nv.IF_curr_exp())
    slow.connect("s", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1, delay=1e12))
    _timed(lambda: nv.compile(slow), r"projection 's->a' \(4 synapses, delays up to 10000000000000 steps\)")
    ok = nv.Network("ok")
    ok.add_population("s", 2, nv.SpikeSourcePoisson(rate=5.0))
    sim = nv.compile(ok)
    _timed(
        lambda: sim.run(1e12),
        r"run: 1e\+12 ms \(10000000000000 steps of 0.1 ms\) of network 'ok' needs about .* operations; the limit is 1e\+12",
    )
    monkeypatch.setenv("NEUROVPR_MAX_WORK", "100")
    _timed(lambda: sim.run(10.0), r"the limit is 100 \(NEUROVPR_MAX_WORK\)")
    monkeypatch.setenv("NEUROVPR_MAX_MEMORY", "100")
    _timed(lambda: nv.compile(ok), r"the limit is 100 B \(NEUROVPR_MAX_MEMORY\)")


def test_run_inputs_must_be_a_mapping() -> None:
    net = nv.Network("n")
    net.add_population("s", 3, nv.SpikeSourcePoisson(rate=5.0))
    sim = nv.compile(net)
    with pytest.raises(
        nv.ValidationError,
        match=r"run: inputs must be a mapping \{population name: rates or spike times\}, got list; the sources are 's'",
    ):
        sim.run(10, inputs=[1, 2, 3])
