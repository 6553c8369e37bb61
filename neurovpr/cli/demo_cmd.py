"""``neurovpr demo``: the main job on the embedded default.

Trains one Diehl & Cook module (Poisson pixels -> adaptive excitatory layer with
lateral inhibition, learned by ``DiehlCookSTDP``) on a handful of synthetic
patterns with the reference backend, assigns each neuron to the pattern it fires
most for, and reports how well the module tells noisy versions of the patterns
apart. Writes ``summary.json`` and a PNG of the learned weights to the report folder.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

import neurovpr as nv
from neurovpr.fileio import atomic_write_text

_SIDE = 28


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser("demo", help="train and evaluate a small module on synthetic patterns")
    p.add_argument("--out", type=Path, default=Path("reports/demo"), help="report folder (default: reports/demo)")
    p.add_argument("--backend", default="reference", help="backend to run on (default: reference)")
    p.add_argument("--patterns", type=int, default=5, help="number of patterns (2..20, default 5)")
    p.add_argument("--epochs", type=int, default=10, help="training epochs (1..50, default 10)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(handler=run)


def _patterns(n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` random blob images of ``_SIDE x _SIDE`` pixels in 0..255."""
    yy, xx = np.mgrid[0:_SIDE, 0:_SIDE]
    out = np.zeros((n, _SIDE * _SIDE))
    for k in range(n):
        img = np.zeros((_SIDE, _SIDE))
        for _ in range(3):
            cy, cx = rng.uniform(0, _SIDE, 2)
            img += np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (2 * 4.0**2))
        out[k] = 255 * img.ravel() / img.max()
    return out


def build_module(n_input: int, n_neurons: int) -> nv.Network:
    """A Diehl & Cook module with conductances in units of the leak conductance (cm = tau_m)."""
    net = nv.Network("demo_module")
    net.add_population("pixels", n_input, nv.SpikeSourcePoisson())
    exc = nv.IF_cond_exp_adaptive(
        cm=100.0, tau_m=100.0, v_rest=-65.0, v_reset=-65.0, v_thresh=-52.0, tau_refrac=5.0,
        tau_syn_E=1.0, tau_syn_I=2.0, e_rev_E=0.0, e_rev_I=-100.0, theta_plus=0.05, tau_theta=1e7,
    )  # fmt: skip
    inh = nv.IF_cond_exp(
        cm=10.0, tau_m=10.0, v_rest=-60.0, v_reset=-45.0, v_thresh=-40.0, tau_refrac=2.0,
        tau_syn_E=1.0, tau_syn_I=2.0, e_rev_E=0.0, e_rev_I=-85.0,
    )  # fmt: skip
    net.add_population("exc", n_neurons, exc)
    net.add_population("inh", n_neurons, inh)
    net.connect(
        "pixels", "exc", nv.AllToAllConnector(),
        nv.DiehlCookSTDP(weight=nv.Uniform(low=0.0, high=0.3), eta_pre=1e-4, eta_post=1e-2, w_max=1.0, mu=1.0),
    )  # fmt: skip
    net.connect("exc", "inh", nv.OneToOneConnector(), nv.StaticSynapse(weight=10.4))
    net.connect(
        "inh", "exc", nv.AllToAllConnector(allow_self_connections=False), nv.StaticSynapse(weight=17.0),
        receptor_type="inhibitory", name="lateral",
    )  # fmt: skip
    return net


def run(args: argparse.Namespace) -> int:
    """Train, assign, test and report."""
    if not 2 <= args.patterns <= 20:
        raise nv.ValidationError(f"demo: --patterns must be in 2..20, got {args.patterns}.")
    if not 1 <= args.epochs <= 50:
        raise nv.ValidationError(f"demo: --epochs must be in 1..50, got {args.epochs}.")
    rng = np.random.default_rng(args.seed)
    patterns = _patterns(args.patterns, rng)
    n_neurons = 10 * args.patterns
    net = build_module(patterns.shape[1], n_neurons)
    start = time.perf_counter()
    sim = nv.compile(net, backend=args.backend, dt=0.5, seed=args.seed)

    def present(img: np.ndarray) -> np.ndarray:
        sim.run(350.0, inputs={"pixels": img / 4.0})
        counts = sim.spike_counts("exc")
        sim.reset()
        return counts

    order = [k for _ in range(args.epochs) for k in rng.permutation(args.patterns)]
    for k in tqdm(order, desc="training", unit="image"):
        w = sim.weights("pixels->exc")  # Diehl & Cook: input weights of each neuron sum to 78
        sim.set_weights("pixels->exc", np.minimum(w * (78.0 / w.sum(axis=0)), 1.0))
        present(patterns[k])
    train_s = time.perf_counter() - start
    sim.plasticity(False)
    responses = np.array([present(p) for p in patterns])
    assignment = responses.argmax(axis=0)
    labels = np.repeat(np.arange(args.patterns), 4)  # four noisy versions of each pattern
    noisy = np.clip(patterns[labels] + rng.normal(0, 40.0, (labels.size, patterns.shape[1])), 0, 255)
    correct = 0
    for k, img in zip(labels, tqdm(noisy, desc="testing", unit="image"), strict=True):
        counts = present(img)
        scores = np.array([counts[assignment == c].sum() for c in range(args.patterns)])
        correct += int(scores.argmax() == k and scores.max() > 0)
    accuracy = correct / labels.size
    summary = {
        "model": "diehl_cook_module",
        "backend": args.backend,
        "patterns": args.patterns,
        "neurons": n_neurons,
        "epochs": args.epochs,
        "accuracy": accuracy,
        "chance": 1.0 / args.patterns,
        "train_seconds": round(train_s, 3),
        "activity": sim.statistics(),
    }
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / "summary.json", json.dumps(summary, indent=2))
    _plot_weights(sim.weights("pixels->exc"), args.out / "weights.png")
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"Diehl&Cook module, {n_neurons} neurons, {args.patterns} patterns, {args.epochs} epochs, {args.backend}")
        print(f"  accuracy on noisy patterns: {accuracy:.0%} (chance {1 / args.patterns:.0%})")
        print(f"  training time: {train_s:.1f} s; report written to {args.out}")
    return 0


def _plot_weights(weights: np.ndarray, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = weights.shape[1]
    cols = min(n, 10)
    rows = int(np.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(cols, rows))
    for k, ax in enumerate(np.atleast_1d(axes).ravel()):
        ax.axis("off")
        if k < n:
            ax.imshow(weights[:, k].reshape(_SIDE, _SIDE), cmap="gray")
    fig.suptitle("learned input weights per excitatory neuron")
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=80)
    plt.close(fig)
    tmp.replace(path)
