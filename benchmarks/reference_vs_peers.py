"""Reference backend vs NEST 3 and Brian2's C++ standalone device: same networks, same spikes, one run.

Three networks, each run on every simulator that can run it natively, with the same input
spikes (drawn once here and given to every simulator as a ``SpikeSourceArray``), the same
``dt`` and the same seed:

``dc``
    One Diehl & Cook module of the Modular SNN (784 inputs, 400 + 400 conductance neurons,
    ``DiehlCookSTDP`` on the input projection; :func:`reference_vs_brian2.build_module`),
    shown ``--images`` synthetic images as one continuous run (no normalisation between
    images, which Brian2's standalone device cannot run from Python). Peers: Brian2
    cpp_standalone with 1 and 2 OpenMP threads. NEST cannot run it: NEST has no
    Diehl & Cook triplet rule (pre-synaptic depression by the post trace, post-synaptic
    potentiation by the pre trace and the post's slow trace) and no adaptive-threshold
    conductance neuron; PyNN offers neither.
``stdp``
    A sparse recurrent IF_curr_exp network of excitatory and inhibitory neurons driven by
    Poisson inputs through pair-STDP synapses (additive weight dependence), all other
    projections static, at dt = 0.1 ms. Peers: NEST (through the ``pynn`` backend: PyNN's
    standard models on NEST, STDP as ``stdp_synapse``) with 1 and 2 threads, and Brian2
    cpp_standalone with 1 and 2 OpenMP threads.
``locsnet``
    LoCS-Net inference (initialised, untrained weights; regular input spike trains), one
    reset and one presentation per query. Peers: NEST through the ``pynn`` backend (the
    convolutions expanded into lists of connections) with 1 and 2 threads, and the torch
    rate model of the same weights (one image at a time) with 1 and 2 torch threads.

The reference backend runs on one thread. Every run reports wall and CPU seconds (CPU of
this process and, for the standalone binary and its compiler, of child processes),
synaptic events per second of wall time, and the spike statistics that show equal work.
Brian2's code generation and C++ compilation and numba's first call (compilation, or
loading of numba's cache) are reported apart from run time. Ratios are peer / reference
in the same run (above 1: the reference is faster).

Usage (from the repository root)::

    python benchmarks/reference_vs_peers.py [--quick] [--networks dc,stdp,locsnet] [--json OUT] [--png OUT]

``--quick`` runs every peer at a tiny size (a few seconds each plus compilation, which
it does without optimisation) and checks that the runs did the same work
(:data:`TOLERANCE`); the command exits 1 when they did not. With ``--threads 1`` the default
sizes took about 15 minutes on this project's 2-core development machine while it was
shared, most of it Brian2's compilation (2-3 minutes per network and thread count) and
PyNN building the networks on NEST. The ``pynn`` backend's ``reset()`` builds the NEST
network again, so NEST's LoCS-Net time per query includes that construction; the backend
reports its wall time inside NEST's run apart from rebuilding (``statistics()``:
``run_wall_ns``, ``build_wall_ns``), printed as "of the run" lines and stored as
``simulate_seconds`` and ``rebuild_seconds``.
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.ir.connectivity import expand
from neurovpr.paths import cache_dir

sys.path.insert(0, str(Path(__file__).resolve().parent))
from reference_vs_brian2 import DT as DC_DT
from reference_vs_brian2 import PRESENT_MS, build_module, poisson_events

#: Largest relative difference of total spike counts accepted between simulators, per
#: network. D&C on Brian2: the same arithmetic up to round-off (exact integration of the
#: conductance neuron is done in a different order). stdp: NEST integrates IF_curr_exp
#: exactly as the reference does, but a recurrent network amplifies round-off differences
#: (and NEST's STDP pairs spikes with the dendritic delay), so spike trains diverge
#: while rates agree. locsnet: NEST's exact integration against the reference's.
TOLERANCE = {"dc": 0.02, "stdp": 0.05, "locsnet": 0.02}
THREADS = (1, 2)


@dataclass
class Timing:
    """Wall and CPU seconds of one block (CPU: this process plus finished child processes)."""

    wall: float = 0.0
    cpu: float = 0.0

    @classmethod
    def of(cls, fn: Callable[[], Any]) -> tuple[Any, Timing]:
        """Call ``fn`` and time it."""
        w0, c0, k0 = time.perf_counter(), time.process_time(), _children_cpu()
        out = fn()
        return out, cls(time.perf_counter() - w0, time.process_time() - c0 + _children_cpu() - k0)


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _record(name: str, threads: int, run: Timing, setup: Timing, stats: dict[str, Any], **extra: Any) -> dict:
    events = int(stats.get("synaptic_events", 0))
    return {
        "simulator": name,
        "threads": threads,
        "run_seconds": run.wall,
        "run_cpu_seconds": run.cpu,
        "setup_seconds": setup.wall,
        "setup_cpu_seconds": setup.cpu,
        "synaptic_events": events,
        "events_per_second": events / run.wall if run.wall > 0 else 0.0,
        "events_per_cpu_second": events / run.cpu if run.cpu > 0 else 0.0,
        **{k: v for k, v in stats.items() if k != "synaptic_events"},
        **extra,
    }


# -- the simulators --------------------------------------------------------------------------
def run_reference(network: nv.Network, duration: float, dt: float, seed: int, watch: tuple[str, ...]) -> dict:
    """Compile, call once for one step (numba's first call), then time one run of ``duration``."""
    sim, setup = Timing.of(lambda: nv.compile(network, backend="reference", dt=dt, seed=seed))
    _, first = Timing.of(lambda: sim.run(dt))
    sim.reset()
    before = sim.statistics()
    _, run = Timing.of(lambda: sim.run(duration))
    stats = _difference(sim.statistics(), before)
    stats["spikes_of"] = {p: int(sim.spike_counts(p).sum()) for p in watch}
    return _record("reference", 1, run, setup, stats, first_call_seconds=first.wall)


def run_nest(network: nv.Network, duration: float, dt: float, seed: int, watch: tuple[str, ...], threads: int) -> dict:
    """NEST 3 through the ``pynn`` backend (PyNN's standard models), ``threads`` NEST threads."""
    sim, setup = Timing.of(lambda: nv.compile(network, backend="pynn", dt=dt, seed=seed, threads=threads))
    before = sim.statistics()
    _, run = Timing.of(lambda: sim.run(duration))
    stats = _difference(sim.statistics(), before)
    stats["spikes_of"] = {p: int(sim.spike_counts(p).sum()) for p in watch}
    sim.close()
    return _record("nest", threads, run, setup, stats)


def run_brian2_standalone(
    network: nv.Network, duration: float, dt: float, seed: int, watch: tuple[str, ...], threads: int,
    *, optimise: bool = True,
) -> dict:  # fmt: skip
    """Brian2's C++ standalone device; ``threads`` > 1 runs it with that many OpenMP threads.

    The network is built with the ``brian2`` backend's own builders (the same equation
    templates as its runtime targets), generated, compiled and run once. ``setup``
    is code generation plus compilation; the run is the standalone binary (its process
    start and result files included); ``loop_seconds`` is the binary's own timing of
    its simulation loop. The project folder is kept between runs (``neurovpr.paths.cache_dir``),
    so that ``make`` rebuilds only what changed; ``optimise=False`` compiles with ``-O0``
    (a quick correctness run).
    """
    import brian2 as b2

    from neurovpr.backends.brian2 import build

    folder = cache_dir("brian2_standalone") / f"{network.name}-t{threads}{'' if optimise else '-O0'}"
    directory = str(folder)
    b2.set_device("cpp_standalone", build_on_run=False, directory=directory)
    b2.prefs.devices.cpp_standalone.openmp_threads = threads if threads > 1 else 0
    flags = b2.prefs.codegen.cpp.extra_compile_args_gcc
    if not optimise:
        b2.prefs.codegen.cpp.extra_compile_args_gcc = ["-w", "-O0"]
    try:

        def generate() -> tuple[dict, dict]:
            clock = b2.Clock(dt=dt * 1e-3 * b2.second, name="neurovpr_clock")
            ctx = build.BuildContext(clock=clock, codeobj_class=None, dt=dt)
            pops = {name: build.build_population(pop, ctx) for name, pop in network.populations.items()}
            projs = {}
            for name, proj in network.projections.items():
                conns = expand(network, proj, dt=dt, seed=seed)
                projs[name] = build.build_projection(proj, conns, ctx, pops[proj.pre], pops[proj.post])
            objects = [o for h in pops.values() for o in (h.group, h.spikes)] + [h.synapses for h in projs.values()]
            b2.seed(seed)
            b2.Network(*objects).run(duration * 1e-3 * b2.second, namespace={}, report=None)
            b2.device.build(directory=directory, compile=True, run=False, with_output=False)
            return pops, projs

        (pops, projs), setup = Timing.of(generate)
        _, run = Timing.of(lambda: b2.device.run(directory=directory, with_output=False))
        counts = {name: np.asarray(h.spikes.count[:], dtype=np.int64) for name, h in pops.items()}
        events = 0
        for h in projs.values():
            if not np.array_equal(np.asarray(h.synapses.i[:]), h.pre):
                raise RuntimeError(f"Brian2 standalone reordered the synapses of {h.name!r}")
            if h.model.plastic:
                events += int(np.rint(build.get_values(h.synapses, "n_events").sum()))
            else:
                events += int(counts[h.pre_population] @ h.out_degree)
        neurons = [h for h in pops.values() if h.kind == "neuron"]
        stats = {
            "spikes": int(sum(c.sum() for c in counts.values())),
            "synaptic_events": events,
            "neuron_updates": round(duration / dt) * sum(h.size for h in neurons),
            "spikes_of": {p: int(counts[p].sum()) for p in watch},
        }
        loop = float(b2.device._last_run_time or 0.0)
    finally:
        b2.prefs.codegen.cpp.extra_compile_args_gcc = flags
        b2.device.reinit()
        b2.device.activate()
        b2.set_device("runtime")
    return _record("brian2-cpp", threads, run, setup, stats, loop_seconds=loop)


def _difference(after: dict[str, int], before: dict[str, int]) -> dict[str, int]:
    return {k: int(after[k] - before.get(k, 0)) for k in ("spikes", "synaptic_events", "neuron_updates")}


# -- the networks ----------------------------------------------------------------------------
def dc_network(n_images: int, seed: int) -> tuple[nv.Network, float]:
    """The Diehl & Cook module fed ``n_images`` synthetic images back to back."""
    events = poisson_events(n_images, np.random.default_rng(seed))
    t = np.concatenate([ti + k * PRESENT_MS for k, (ti, _) in enumerate(events)])
    n = np.concatenate([ni for _, ni in events])
    return build_module(nv.SpikeSourceArray.from_events(t, n, 784), seed), n_images * PRESENT_MS


def stdp_network(n_exc: int, n_input: int, duration: float, seed: int, dt: float = 0.1) -> nv.Network:
    """A sparse E/I network of IF_curr_exp neurons with pair-STDP input synapses.

    ``n_exc`` excitatory and ``n_exc // 4`` inhibitory neurons; ``n_input`` Poisson inputs at
    8 Hz (drawn once) reach each neuron with probability 0.1 (plastic onto the excitatory
    neurons); recurrent connections are static with probability 0.05 (E->E 0.02), 1 ms delays.
    Weights are scaled with the number of inputs so that rates stay near a few Hz at any size.
    """
    rng = np.random.default_rng(seed)
    steps = round(duration / dt)
    fire = rng.random((steps, n_input)) < 8.0 * dt * 1e-3
    t_idx, n_idx = np.nonzero(fire)
    n_inh = n_exc // 4
    net = nv.Network("stdp_ei")
    net.add_population("input", n_input, nv.SpikeSourceArray.from_events(t_idx * dt, n_idx, n_input))
    cell = nv.IF_curr_exp(cm=0.25, tau_m=20.0, tau_refrac=2.0, tau_syn_E=5.0, tau_syn_I=5.0,
                          v_rest=-65.0, v_reset=-65.0, v_thresh=-50.0)  # fmt: skip
    net.add_population("exc", n_exc, cell)
    net.add_population("inh", n_inh, cell)
    k_in = 0.1 * n_input  # inputs per neuron
    w_in = 0.4 / k_in * 50.0  # nA
    stdp = nv.STDPMechanism(
        timing_dependence=nv.SpikePairRule(tau_plus=16.8, tau_minus=33.7, A_plus=0.005, A_minus=0.00525),
        weight_dependence=nv.AdditiveWeightDependence(w_min=0.0, w_max=2.0 * w_in),
        weight=w_in, delay=1.0,
    )  # fmt: skip
    net.connect("input", "exc", nv.FixedProbabilityConnector(p_connect=0.1, seed=seed + 1), stdp, name="in_exc")
    net.connect("input", "inh", nv.FixedProbabilityConnector(p_connect=0.1, seed=seed + 2),
                nv.StaticSynapse(weight=w_in, delay=1.0), name="in_inh")  # fmt: skip
    w_e = 0.05 * 4000.0 / n_exc
    w_i = -0.2 * 1000.0 / n_inh
    for k, (pre, post, p, w) in enumerate(
        [("exc", "exc", 0.02, w_e), ("exc", "inh", 0.05, w_e), ("inh", "exc", 0.05, w_i), ("inh", "inh", 0.05, w_i)]
    ):
        receptor = "inhibitory" if w < 0 else "excitatory"
        net.connect(pre, post, nv.FixedProbabilityConnector(p_connect=p, seed=seed + 3 + k, allow_self_connections=False),
                    nv.StaticSynapse(weight=abs(w), delay=1.0), receptor_type=receptor, name=f"{pre}_{post}")  # fmt: skip
    return net


# -- LoCS-Net inference ----------------------------------------------------------------------
def locsnet_case(n_places: int, n_queries: int, seed: int, *, small: bool) -> tuple[Any, ...]:
    """An initialised (untrained) LoCS-Net, its spiking network with regular input, and query images."""
    import torch

    from neurovpr.models.locsnet import SpikingParameters, paper_architecture, small_architecture, to_spiking_network
    from neurovpr.models.locsnet.torchnet import LoCSNetTorch, to_numpy_parameters

    arch = small_architecture(n_places) if small else paper_architecture(n_places)
    rng = np.random.default_rng(seed)
    h, w = arch.input_size
    images = rng.random((max(n_queries, 64), h, w))
    torch.manual_seed(seed)
    model = LoCSNetTorch(arch)
    model.initialise(torch.as_tensor(images[:64, None], dtype=torch.float32), 1.2, 1.0)  # training's defaults
    spiking = SpikingParameters(input_coding="regular")
    net = to_spiking_network(arch, to_numpy_parameters(model, quantised=False), spiking)
    return arch, spiking, net, model, images[:n_queries]


def run_locsnet_spiking(case: tuple[Any, ...], backend: str, threads: int) -> dict:
    """Every query (reset, regular input spikes, one presentation) on ``backend``; the first query is a warm-up."""
    from neurovpr.models.locsnet import SpikingClassifier

    arch, spiking, net, _, images = case
    options = {"threads": threads} if backend == "pynn" else {}
    clf, setup = Timing.of(lambda: SpikingClassifier(net, arch, spiking, backend=backend, **options))
    _, first = Timing.of(lambda: clf.run(images[:1]))
    result, run = Timing.of(lambda: clf.run(images))
    totals = result.totals or {}
    stats = {k: int(totals.get(k, 0)) for k in ("spikes", "synaptic_events", "neuron_updates")}
    stats["spikes_of"] = {k: round(v * len(images)) for k, v in result.layer_spikes.items()}
    stats["answers"] = [int(a) for a in result.counts.argmax(axis=0)]
    extra = {}
    if "run_wall_ns" in totals:  # the pynn backend: NEST's own run apart from rebuilding the network at every reset
        extra = {"simulate_seconds": totals["run_wall_ns"] / 1e9, "rebuild_seconds": totals.get("build_wall_ns", 0) / 1e9}
    if backend == "pynn":
        clf.sim.close()
    name = "reference" if backend == "reference" else "nest"
    return _record(name, threads, run, setup, stats, first_call_seconds=first.wall, per_query_ms=1e3 * run.wall / len(images),
                   **extra)  # fmt: skip


def run_locsnet_torch(case: tuple[Any, ...], threads: int) -> dict:
    """The torch rate model of the same weights, one image at a time, ``threads`` torch threads."""
    import torch

    _, _, _, model, images = case
    old = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        x = torch.as_tensor(images[:, None], dtype=torch.float32)
        with torch.no_grad():
            model(x[:1])

            def forward() -> list[int]:
                return [int(model(x[q : q + 1])[0].argmax()) for q in range(x.shape[0])]

            answers, run = Timing.of(forward)
    finally:
        torch.set_num_threads(old)
    return _record("torch-rate", threads, run, Timing(), {"answers": answers, "spikes_of": {}},
                   per_query_ms=1e3 * run.wall / len(images))  # fmt: skip


# -- the comparison --------------------------------------------------------------------------
#: Sizes: (full, --quick).
SIZES = {
    "dc": ({"images": 10}, {"images": 1}),
    "stdp": ({"n_exc": 4000, "n_input": 1000, "duration": 1000.0}, {"n_exc": 200, "n_input": 50, "duration": 100.0}),
    "locsnet": ({"places": 500, "queries": 4}, {"places": 20, "queries": 3}),
}

#: Why a simulator does not run a network.
NOT_RUN = {
    ("dc", "nest"): "NEST (and PyNN) have no Diehl & Cook triplet rule and no adaptive-threshold conductance neuron",
    ("locsnet", "brian2-cpp"): "not measured: LoCS-Net inference is a reset and a short run per query, which Brian2's "
    "standalone device would run as one generated program per query",
}


def compare(networks: list[str], *, quick: bool, seed: int, threads: tuple[int, ...]) -> dict[str, Any]:
    """Run every network on every simulator; return the records per network."""
    out: dict[str, Any] = {}
    pick = 1 if quick else 0
    for name in networks:
        size = SIZES[name][pick]
        runs: list[dict] = []
        print(f"[{name}] {size}", flush=True)
        if name == "dc":
            net, duration = dc_network(size["images"], seed)
            watch = ("exc", "inh")
            runs.append(run_reference(net, duration, DC_DT, seed, watch))
            runs += [run_brian2_standalone(net, duration, DC_DT, seed, watch, t, optimise=not quick) for t in threads]
        elif name == "stdp":
            duration = size["duration"]
            net = stdp_network(size["n_exc"], size["n_input"], duration, seed)
            watch = ("exc", "inh")
            runs.append(run_reference(net, duration, 0.1, seed, watch))
            runs += [run_nest(net, duration, 0.1, seed, watch, t) for t in threads]
            runs += [run_brian2_standalone(net, duration, 0.1, seed, watch, t, optimise=not quick) for t in threads]
        elif name == "locsnet":
            case = locsnet_case(size["places"], size["queries"], seed, small=quick)
            runs.append(run_locsnet_spiking(case, "reference", 1))
            runs += [run_locsnet_spiking(case, "pynn", t) for t in threads]
            runs += [run_locsnet_torch(case, t) for t in threads]
        ref = runs[0]
        for r in runs:
            r["ratio_wall"] = r["run_seconds"] / ref["run_seconds"]
            r["ratio_cpu"] = r["run_cpu_seconds"] / ref["run_cpu_seconds"]
        out[name] = {
            "size": size,
            "runs": runs,
            "not_run": {sim: why for (net_name, sim), why in NOT_RUN.items() if net_name == name},
            "same_work": same_work(name, runs),
        }
        print_table({name: out[name]})
    return out


def same_work(name: str, runs: list[dict]) -> dict[str, Any]:
    """Relative differences of spike counts (per watched population) to the reference's."""
    ref = runs[0]["spikes_of"]
    worst = 0.0
    diffs = {}
    for r in runs[1:]:
        if not r["spikes_of"]:
            continue
        key = f"{r['simulator']}-t{r['threads']}"
        diffs[key] = {p: abs(r["spikes_of"][p] - n) / max(n, 1) for p, n in ref.items()}
        worst = max(worst, *diffs[key].values())
    answers = {f"{r['simulator']}-t{r['threads']}": float(np.mean(np.equal(r["answers"], runs[0]["answers"])))
               for r in runs[1:] if "answers" in r}  # fmt: skip
    return {"relative_spike_difference": diffs, "worst": worst, "tolerance": TOLERANCE[name],
            "ok": worst <= TOLERANCE[name], "answers_agree": answers}  # fmt: skip


def print_table(results: dict[str, Any]) -> None:
    """One line per run: seconds, ratio to the reference, events per second, spikes."""
    head = f"{'network':9s}{'simulator':12s}{'thr':>4s}{'setup s':>9s}{'1st call':>9s}{'run s':>9s}{'cpu s':>9s}"
    print(head + f"{'ratio':>8s}{'cpu ratio':>10s}{'syn ev/s':>10s}  spikes")
    for name, res in results.items():
        for r in res["runs"]:
            first = r.get("first_call_seconds")
            print(
                f"{name:9s}{r['simulator']:12s}{r['threads']:4d}{r['setup_seconds']:9.2f}"
                f"{'' if first is None else f'{first:.2f}':>9s}{r['run_seconds']:9.3f}{r['run_cpu_seconds']:9.3f}"
                f"{r['ratio_wall']:8.2f}{r['ratio_cpu']:10.2f}{r['events_per_second']:10.3g}  {r['spikes_of']}"
            )
        for r in res["runs"]:
            if r.get("simulate_seconds") is not None:
                print(f"{name:9s}{r['simulator']:12s}{r['threads']:4d}  of the run: {r['simulate_seconds']:.3f} s in the "
                      f"simulator's run ({r['simulate_seconds'] / res['runs'][0]['run_seconds']:.2f} x the reference's run), "
                      f"{r['rebuild_seconds']:.3f} s rebuilding the network at resets")  # fmt: skip
        for sim, why in res["not_run"].items():
            print(f"{name:9s}{sim:12s}  not run: {why}")
        same = res["same_work"]
        print(f"{name:9s}same work: worst relative spike difference {same['worst']:.4f} (tolerance {same['tolerance']}), "
              f"answers agreeing with the reference {same['answers_agree'] or '-'}")  # fmt: skip


def plot(results: dict[str, Any], path: Path) -> None:
    """Bar chart: run wall seconds per simulator and thread count, one panel per network (log scale)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(4.5 * len(results), 3.6), squeeze=False)
    for ax, (name, res) in zip(axes[0], results.items(), strict=True):
        labels = [f"{r['simulator']}\n{r['threads']} thr" for r in res["runs"]]
        ax.bar(range(len(labels)), [r["run_seconds"] for r in res["runs"]], color="tab:blue")
        ax.set_xticks(range(len(labels)), labels, fontsize=7)
        ax.set_yscale("log")
        ax.set_ylabel("run wall seconds")
        ax.set_title(f"{name} {res['size']}", fontsize=8)
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(path)


def main(argv: list[str] | None = None) -> int:
    """Run the comparison; print the table; write JSON and PNG; exit 1 when the runs did not do the same work."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny sizes, every simulator, check equal work")
    parser.add_argument("--networks", default="stdp,dc,locsnet")
    parser.add_argument("--threads", default="1,2", help="thread counts of the peers (comma-separated)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--png", type=Path, default=None)
    args = parser.parse_args(argv)
    networks = [n for n in args.networks.split(",") if n]
    unknown = sorted(set(networks) - set(SIZES))
    if unknown:
        parser.error(f"unknown network(s) {unknown}; choose from {sorted(SIZES)}")
    threads = tuple(int(t) for t in args.threads.split(","))
    results = compare(networks, quick=args.quick, seed=args.seed, threads=threads)
    print(f"machine: {platform.machine()}, {platform.processor() or '?'}; quick={args.quick}")
    payload = {"machine": platform.machine(), "quick": args.quick, "networks": results}
    if args.json:
        tmp = args.json.with_suffix(".tmp")
        tmp.write_text(json.dumps(payload, indent=2))
        tmp.replace(args.json)
    if args.png:
        plot(results, args.png)
    return 0 if all(res["same_work"]["ok"] for res in results.values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
