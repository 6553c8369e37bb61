"""The torch backend: batched inference equal to the reference backend on the same input spikes."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv

pytest.importorskip("torch")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "runtime"))
from batch_networks import array_items, conv_current, diehl_cook_like


def _assert_same_spikes(a: nv.BatchResult, b: nv.BatchResult) -> None:
    assert a.counts.keys() == b.counts.keys()
    for name in a.counts:
        np.testing.assert_array_equal(a.counts[name], b.counts[name], err_msg=name)
        for k, ((ta, ia), (tb, ib)) in enumerate(zip(a.trains[name], b.trains[name], strict=True)):
            np.testing.assert_array_equal(ta, tb, err_msg=f"{name} item {k}")
            np.testing.assert_array_equal(ia, ib, err_msg=f"{name} item {k}")


@pytest.mark.parametrize("fuse", [False, True], ids=["eager", "fused"])
@pytest.mark.parametrize(
    ("build", "source", "n_in"),
    [
        (conv_current, "image", 72),
        (lambda: diehl_cook_like(poisson=False), "pixels", 30),
        (lambda: diehl_cook_like(poisson=False, integration="euler"), "pixels", 30),
    ],
    ids=["conv-current-ca2", "conductance-adaptive-lockout", "conductance-euler"],
)
def test_spikes_equal_the_reference_backend_on_explicit_input_spikes(build, source: str, n_in: int, fuse: bool) -> None:
    """Eager, and with the option fuse (the neurons' step compiled by torch.compile into one kernel per group)."""
    items = [{source: s} for s in array_items(5, n_in, duration=40.0, rate_hz=300.0, seed=1)]
    ref = nv.compile(build(), backend="reference", dt=0.1, seed=2)
    ref.plasticity(False)
    expected = ref.run_batch(40.0, items, spike_trains=True)
    sim = nv.compile(build(), backend="torch", dt=0.1, seed=2, batch_size=3, fuse=fuse)  # two batches: 3 + 2 items
    got = sim.run_batch(40.0, items, spike_trains=True)
    assert all(expected.counts[name].sum() > 0 for name in expected.counts)
    _assert_same_spikes(expected, got)
    # one item through run() on the torch backend gives the same spikes and membrane as the reference
    ref.record(list(expected.counts)[-1], "v")
    sim.record(list(expected.counts)[-1], "v")
    for s in (ref, sim):
        s.run(40.0, inputs=items[3])
    name = list(expected.counts)[-1]
    np.testing.assert_array_equal(sim.spike_counts(name), expected.counts[name][3])
    np.testing.assert_allclose(sim.trace(name, "v")[1], ref.trace(name, "v")[1], rtol=0, atol=1e-9)


def test_batch_equals_the_run_reset_loop_with_poisson_input() -> None:
    rng = np.random.default_rng(4)
    items = [{"pixels": rng.uniform(0.0, 150.0, 30)} for _ in range(4)]
    loop = nv.compile(diehl_cook_like(), backend="torch", dt=0.1, seed=9)
    rows = []
    for item in items:
        loop.run(30.0, inputs=item)
        rows.append((loop.spike_counts("pixels"), loop.spike_counts("exc")))
        loop.reset()
    got = nv.compile(diehl_cook_like(), backend="torch", dt=0.1, seed=9, batch_size=3).run_batch(30.0, items)
    np.testing.assert_array_equal(got.counts["pixels"], np.stack([r[0] for r in rows]))
    np.testing.assert_array_equal(got.counts["exc"], np.stack([r[1] for r in rows]))
    assert got.counts["exc"].sum() > 0


@pytest.mark.parametrize("fuse", [False, True], ids=["eager", "fused"])
def test_float32_counts_stay_close_to_float64(fuse: bool) -> None:
    items = [{"image": s} for s in array_items(3, 72, duration=30.0, rate_hz=300.0, seed=3)]
    exact = nv.compile(conv_current(), backend="torch", dt=0.1, seed=2).run_batch(30.0, items)
    single = nv.compile(conv_current(), backend="torch", dt=0.1, seed=2, dtype="float32", fuse=fuse).run_batch(30.0, items)
    total = exact.counts["maps"].sum()
    assert abs(int(single.counts["maps"].sum()) - int(total)) <= 0.02 * total


@pytest.mark.parametrize("build", [conv_current, lambda: diehl_cook_like(poisson=False)], ids=["current", "conductance"])
def test_float32_membrane_choice_by_lerp_equals_where(build) -> None:
    """In float32 the step chooses between membranes with lerp (weights exactly 0 or 1); the same spikes and
    membranes as with where."""
    source, n_in = ("image", 72) if build is conv_current else ("pixels", 30)
    items = [{source: s} for s in array_items(3, n_in, duration=40.0, rate_hz=300.0, seed=5)]
    runs = []
    for lerp in (True, False):
        sim = nv.compile(build(), backend="torch", dt=0.1, seed=2, dtype="float32")
        name = [p for p in sim.network.populations if not sim.network.populations[p].is_source][-1]
        sim.record(name, "v")
        sim._net.lerp = lerp  # the choice the backend makes for float32; False is float64's
        runs.append(sim.run_batch(40.0, items, spike_trains=True))
    assert runs[0].counts[name].sum() > 0
    _assert_same_spikes(runs[0], runs[1])
    for key in runs[0].traces:
        np.testing.assert_array_equal(runs[0].traces[key], runs[1].traces[key])


def test_options_and_refusals() -> None:
    import torch

    sim = nv.compile(conv_current(), backend="torch", dt=0.1, seed=1)
    assert sim.device.type == ("cuda" if torch.cuda.is_available() else "cpu")
    with pytest.raises(nv.UnsupportedFeatureError, match="inference"):
        sim.plasticity(True)
    assert not sim.plasticity_enabled
    sim.plasticity(False)
    if not torch.cuda.is_available():
        with pytest.raises(nv.BackendUnavailableError, match="no CUDA device"):
            nv.compile(conv_current(), backend="torch", dt=0.1, seed=1, device="cuda")
    with pytest.raises(nv.ValidationError, match="dtype"):
        nv.compile(conv_current(), backend="torch", dt=0.1, seed=1, dtype="float16")
    with pytest.raises(nv.ValidationError, match="batch_size"):
        nv.compile(conv_current(), backend="torch", dt=0.1, seed=1, batch_size=0)
    with pytest.raises(nv.ValidationError, match="fuse must be True or False, got 'yes'"):
        nv.compile(conv_current(), backend="torch", dt=0.1, seed=1, fuse="yes")
    plastic = diehl_cook_like()
    proj = plastic.projections["pixels->exc"]
    plastic.replace_projection(proj.replace(synapse=nv.DiehlCookSTDP(weight=0.05)))
    with pytest.raises(nv.UnsupportedFeatureError, match="plasticity off"):
        nv.compile(plastic, backend="torch", dt=0.1, seed=1)


def test_a_batch_too_large_for_the_memory_limit_is_refused_before_allocation(monkeypatch: pytest.MonkeyPatch) -> None:
    items = [{"image": s} for s in array_items(4, 72, duration=5.0, rate_hz=100.0, seed=2)]
    sim = nv.compile(conv_current(), backend="torch", dt=0.1, seed=1, batch_size=4)
    monkeypatch.setenv("NEUROVPR_MAX_MEMORY", "100k")
    with pytest.raises(nv.ValidationError, match="batch_size"):
        sim.run_batch(5.0, items)
    monkeypatch.delenv("NEUROVPR_MAX_MEMORY")
    assert sim.run_batch(5.0, items).counts["maps"].shape == (4, 108)


def test_a_batch_larger_than_the_free_device_memory_is_refused_in_one_sentence() -> None:
    """On CUDA the batch's state is checked against the device's free memory (``torch.cuda.mem_get_info``)."""
    from neurovpr.resources import require_memory

    detail = " on cuda:0 (lower the compile option batch_size)"
    require_memory(2**30, "a batch", detail, limit=(2**31, "free on cuda:0"))  # fits: nothing raised
    with pytest.raises(nv.ValidationError) as err:
        require_memory(3 * 2**30, "torch backend: a batch of 4096 items", detail, limit=(2**30, "free on cuda:0"))
    message = str(err.value)
    assert "a batch of 4096 items" in message and "cuda:0" in message and "batch_size" in message
    assert message.count(". ") == 0 and message.endswith(".")


def test_batch_traces_of_every_recordable_equal_the_reference() -> None:
    items = [{"image": s} for s in array_items(3, 72, duration=20.0, rate_hz=300.0, seed=6)]
    traces = {}
    for label, backend, options in (("reference", "reference", {}), ("torch", "torch", {}), ("fused", "torch", {"fuse": True})):
        sim = nv.compile(conv_current(), backend=backend, dt=0.1, seed=2, **options)
        sim.plasticity(False)
        for var in ("v", "isyn_exc", "isyn_inh", "i_ca2"):
            sim.record("places", var, [0, 3])
        traces[label] = sim.run_batch(20.0, items).traces
    for label in ("torch", "fused"):
        assert traces[label].keys() == traces["reference"].keys()
        for key, values in traces["reference"].items():
            assert values.shape == (3, 200, 2)
            np.testing.assert_allclose(traces[label][key], values, rtol=1e-12, atol=1e-12, err_msg=f"{label} {key}")


def test_spiking_pairs_are_those_of_nonzero_in_its_order() -> None:
    import torch

    from neurovpr.backends.torch.build import spiking

    rng = np.random.default_rng(3)
    for density in (0.0, 0.002, 0.3, 1.0):
        block = torch.as_tensor(rng.random((50, 120)) < density)
        for spikes in (block, block.double(), block.float()[:, 20:90]):  # boolean, 0/1 values, a column view
            item, neuron = spiking(spikes)
            want_item, want_neuron = torch.nonzero(spikes, as_tuple=True)
            assert torch.equal(item, want_item) and torch.equal(neuron, want_neuron)


def _dense_input(delay: float | None) -> nv.Network:
    """diehl_cook_like with one delay on its all-to-all input (a dense block), or its per-synapse delays (None)."""
    net = diehl_cook_like(poisson=False)
    if delay is None:
        return net
    proj = net.projections["pixels->exc"]
    weight = np.random.default_rng(7).uniform(0.0, 0.12, 30 * 12)
    net.replace_projection(proj.replace(synapse=nv.StaticSynapse(weight=weight, delay=delay)))
    return net


@pytest.mark.parametrize("delay", [0.1, 2.5, None], ids=["dense-0.1ms", "dense-2.5ms", "per-synapse-delays"])
def test_source_drive_equals_the_reference_in_batches_and_across_runs(
    delay: float | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    from neurovpr.backends.torch import drive

    monkeypatch.setattr(drive, "WINDOW_BYTES", 4096)  # a window of a few steps: many chunks, arrivals carried between them
    items = [{"pixels": s} for s in array_items(4, 30, duration=40.0, rate_hz=300.0, seed=8)]
    ref = nv.compile(_dense_input(delay), backend="reference", dt=0.1, seed=2)
    ref.plasticity(False)
    expected = ref.run_batch(40.0, items, spike_trains=True)
    sim = nv.compile(_dense_input(delay), backend="torch", dt=0.1, seed=2, batch_size=3)
    # inh->exc is a dense block; the input one too with one delay, else a fan-out table padded for the drive
    assert "inh" in sim._net.dense and ("pixels" in sim._net.dense) == (delay is not None)
    got = sim.run_batch(40.0, items, spike_trains=True)
    assert expected.counts["exc"].sum() > 0 and expected.counts["inh"].sum() > 0
    _assert_same_spikes(expected, got)
    # one item in two runs: the input spikes still in flight at the end of the first arrive in the second
    for s in (ref, sim):
        s.run(20.0, inputs=items[1])
        s.run(20.0)
    for name in ("exc", "inh"):
        np.testing.assert_array_equal(sim.spike_counts(name), ref.spike_counts(name))
        np.testing.assert_array_equal(sim.spike_counts(name), expected.counts[name][1])


def test_fuse_without_a_working_compiler_is_refused_in_one_sentence(tmp_path: Path) -> None:
    """torch.compile needs a C++ compiler on a CPU; where it has none, the option fuse says so and names the way out.

    Run in a fresh interpreter whose inductor finds no compiler (``CXX``) and has an empty cache.
    """
    import os
    import subprocess

    script = (
        "import sys; sys.path.insert(0, sys.argv[1]); import neurovpr as nv; "
        "from batch_networks import array_items, conv_current; "
        "items = [{'image': s} for s in array_items(2, 72, duration=5.0, rate_hz=300.0, seed=1)]; "
        "sim = nv.compile(conv_current(), backend='torch', dt=0.1, seed=2, fuse=True)\n"
        "try:\n    sim.run_batch(5.0, items)\nexcept nv.BackendUnavailableError as err:\n    print('REFUSED', err)"
    )
    env = {**os.environ, "CXX": "/nonexistent/c++", "TORCHINDUCTOR_CACHE_DIR": str(tmp_path), "TORCHINDUCTOR_FX_GRAPH_CACHE": "0"}
    runtime = str(Path(__file__).resolve().parents[1] / "runtime")
    out = subprocess.run([sys.executable, "-c", script, runtime], env=env, capture_output=True, text=True, timeout=300)
    line = next((x for x in out.stdout.splitlines() if x.startswith("REFUSED")), out.stdout + out.stderr[-2000:])
    assert "the option fuse needs torch.compile, which failed here" in line and line.endswith("use fuse=False."), line


def test_fused_kernels_stay_private_where_a_library_made_dlopen_global() -> None:
    """PyNEST sets RTLD_GLOBAL for the whole process; the fused step's kernels must still each run their own code.

    In a fresh interpreter with that flag set (as after ``import nest``), batches of 3 and then 2
    items (two compiled shapes) give the eager step's counts; before the fix the second shape ran
    the first shape's kernel (a later kernel's same-named C function resolved to the earlier one).
    """
    import subprocess

    script = (
        "import os, sys; sys.path.insert(0, sys.argv[1]); sys.setdlopenflags(os.RTLD_NOW | os.RTLD_GLOBAL)\n"
        "import numpy as np, neurovpr as nv\nfrom batch_networks import array_items, conv_current\n"
        "items = [{'image': s} for s in array_items(5, 72, duration=5.0, rate_hz=300.0, seed=1)]\n"
        "runs = [nv.compile(conv_current(), backend='torch', dt=0.1, seed=2, batch_size=3, fuse=f).run_batch(5.0, items)"
        " for f in (False, True)]\n"
        "print('SAME' if np.array_equal(runs[0].counts['maps'], runs[1].counts['maps']) else 'DIFFERENT',"
        " sys.getdlopenflags() & os.RTLD_GLOBAL != 0)"
    )
    runtime = str(Path(__file__).resolve().parents[1] / "runtime")
    out = subprocess.run([sys.executable, "-c", script, runtime], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split()[-2:] == ["SAME", "True"], out.stdout  # same counts; the process's flag restored
