"""Reference backend vs Brian2 on one Diehl & Cook module, in the same run.

Trains the same module (784 inputs, 400 excitatory + 400 inhibitory neurons,
``DiehlCookSTDP`` on the input projection) on the same input spikes (Poisson trains
drawn once here and fed to every backend as a ``SpikeSourceArray``), the same
``dt`` and the same seed, on the ``reference`` backend and on Brian2's ``numpy``
and ``cython`` targets, and prints the wall-clock ratios, synaptic events per
second and the spike statistics of each run (they must agree: same network, same
inputs, same numerics up to round-off).

Usage::

    python benchmarks/reference_vs_brian2.py [--places 25] [--epochs 1] [--targets numpy,cython] [--json OUT]

The numba compilation of the reference backend and Brian2's Cython compilation are
done in a warm-up run on one image and not counted. Targets (issue): reference at
least 50x faster than Brian2/numpy and 10x faster than Brian2/cython.

Measured (this repository's 2-core machine, 25 places x 1 epoch, same run, CPU
seconds): reference 0.38 s, Brian2 numpy 9.19 s (23.9x), Brian2 cython 5.62 s (14.6x),
with identical spike counts (307.9 excitatory spikes per image) and final mean weight
on all three. The cython target (10x) is reached, the numpy one (50x) is not. Where the
time goes on the reference backend, per 350 ms image (about 14.5 ms CPU, measured by
switching parts off on the same inputs):

- about 6 ms in the compiled step loop without learning: 700 steps x 1,584 neurons;
  the excitatory conductance neurons receive input almost every step (784 inputs at
  about 16 Hz), so each of their updates evaluates one exponential (exact integration
  of the membrane with the step's mean conductance);
- about 4 ms for plasticity: 1.7 million plastic arrivals (depression, trace, weight
  delivery) and the potentiation of 784 synapses per excitatory spike;
- about 3 ms of Python for the weight normalisation (reading, normalising and writing
  the 313,600 weights), and the rest for input arrays and reset.

Brian2's numpy target does the same arithmetic vectorised per step; at this size its
cost is a per-step overhead of about 50 numpy calls plus the per-run setup, which is
why the gap is about 24x rather than 50x. Closing it further needs the weight
normalisation inside the compiled loop and a cheaper conductance update (for example
tabulating the exponential), which would trade exactness for speed.
"""

from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

import neurovpr as nv

DT = 0.5
PRESENT_MS = 350.0


def build_module(input_spikes: nv.SpikeSourceArray, seed: int) -> nv.Network:
    """The Modular SNN's module, conductances in units of the leak (cm = tau_m)."""
    net = nv.Network("dc_module")
    net.add_population("pixels", 784, input_spikes)
    exc = nv.IF_cond_exp_adaptive(
        cm=100.0, tau_m=100.0, v_rest=-65.0, v_reset=-65.0, v_thresh=-52.0, tau_refrac=5.0,
        tau_syn_E=1.0, tau_syn_I=0.5, e_rev_E=0.0, e_rev_I=-100.0, theta_plus=0.05, tau_theta=1e7,
    )  # fmt: skip
    inh = nv.IF_cond_exp(
        cm=10.0, tau_m=10.0, v_rest=-60.0, v_reset=-45.0, v_thresh=-40.0, tau_refrac=2.0,
        tau_syn_E=1.0, tau_syn_I=0.5, e_rev_E=0.0, e_rev_I=-85.0,
    )  # fmt: skip
    net.add_population("exc", 400, exc)
    net.add_population("inh", 400, inh)
    rng = np.random.default_rng(seed)
    w0 = (rng.random((784, 400)) + 0.01) * 0.3
    net.connect("pixels", "exc", nv.AllToAllConnector(), nv.DiehlCookSTDP(weight=w0, delay=DT))
    net.connect("exc", "inh", nv.OneToOneConnector(), nv.StaticSynapse(weight=10.4, delay=DT))
    net.connect(
        "inh", "exc", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=17.0, delay=DT),
        receptor_type="inhibitory",
    )  # fmt: skip
    return net


def poisson_events(n_images: int, rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """Spike times (ms, from 0) and pixel indices of Poisson trains (at most one spike per step), per synthetic image."""
    steps = int(PRESENT_MS / DT)
    out = []
    for _ in range(n_images):
        img = rng.uniform(0, 255, 784) * (rng.random(784) < 0.5)
        p = img / 4.0 * DT / 1000.0
        fire = rng.random((steps, 784)) < p
        t_idx, n_idx = np.nonzero(fire)
        out.append((t_idx * DT, n_idx))
    return out


def poisson_images(n_images: int, rng: np.random.Generator) -> list[nv.SpikeSourceArray]:
    """One set of Poisson spike trains per synthetic image (:func:`poisson_events`)."""
    return [nv.SpikeSourceArray.from_events(t, n, 784) for t, n in poisson_events(n_images, rng)]


def train(backend: str, images: list[nv.SpikeSourceArray], epochs: int, seed: int, **options: object) -> dict:
    """Present every image ``epochs`` times with weight normalisation; return timing and statistics."""
    sim = nv.compile(build_module(images[0], seed), backend=backend, dt=DT, seed=seed, **options)
    sim.run(PRESENT_MS, inputs={"pixels": images[0]})  # warm-up: JIT / code generation
    sim.reset()
    before = sim.statistics()
    counts = []
    start, cpu_start = time.perf_counter(), time.process_time()
    _, post = sim.connections("pixels->exc")
    for _ in range(epochs):
        for img in images:
            w = sim.weights("pixels->exc", format="list")  # Diehl & Cook: inputs of each neuron sum to 78
            sim.set_weights("pixels->exc", np.minimum(w * (78.0 / np.bincount(post, weights=w))[post], 1.0))
            sim.run(PRESENT_MS, inputs={"pixels": img})
            counts.append(sim.spike_counts("exc").copy())
            sim.reset()
    seconds = time.perf_counter() - start
    cpu_seconds = time.process_time() - cpu_start
    after = sim.statistics()
    events = after["synaptic_events"] - before["synaptic_events"]
    counts_arr = np.array(counts)
    return {
        "seconds": seconds,
        "cpu_seconds": cpu_seconds,
        "synaptic_events": int(events),
        "events_per_second": events / seconds,
        "exc_spikes_per_image": float(counts_arr.sum(axis=1).mean()),
        "active_neurons_per_image": float((counts_arr > 0).sum(axis=1).mean()),
        "final_weight_mean": float(np.nanmean(sim.weights("pixels->exc"))),
    }


def main() -> None:
    """Run the comparison and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--places", type=int, default=25)
    parser.add_argument("--epochs", type=int, default=1)
    parser.add_argument("--targets", default="numpy,cython", help="Brian2 targets to compare (comma-separated)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    images = poisson_images(args.places, np.random.default_rng(args.seed))
    results = {"reference": train("reference", images, args.epochs, args.seed)}
    for target in [t for t in args.targets.split(",") if t]:
        results[f"brian2-{target}"] = train("brian2", images, args.epochs, args.seed, target=target)
    ref = results["reference"]["seconds"]
    ref_cpu = results["reference"]["cpu_seconds"]
    print(f"Diehl&Cook module 784-400-400, {args.places} places x {args.epochs} epoch(s), dt={DT} ms, "
          f"{PRESENT_MS:.0f} ms per image; machine: {platform.processor() or platform.machine()}")  # fmt: skip
    print(f"{'backend':16s}{'wall s':>9s}{'ratio':>8s}{'cpu s':>9s}{'ratio':>8s}{'syn ev/s':>11s}"
          f"{'exc spikes/img':>16s}{'mean w':>9s}")  # fmt: skip
    for name, r in results.items():
        r["ratio_to_reference"] = r["seconds"] / ref
        r["cpu_ratio_to_reference"] = r["cpu_seconds"] / ref_cpu
        print(
            f"{name:16s}{r['seconds']:9.2f}{r['ratio_to_reference']:8.1f}{r['cpu_seconds']:9.2f}"
            f"{r['cpu_ratio_to_reference']:8.1f}{r['events_per_second']:11.3g}"
            f"{r['exc_spikes_per_image']:16.1f}{r['final_weight_mean']:9.4f}"
        )
    if args.json:
        args.json.write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
