"""``neurovpr demo``: the main job on the embedded default.

Renders a small synthetic route (:func:`neurovpr.data.synthetic.synthetic_traverse`:
a summer reference traverse and a late-autumn query traverse of the same places:
half-way to winter, dimmer, less contrast, slightly blurred, up to 2 pixels off the
reference path),
trains the Modular SNN on it with the reference backend in local worker processes, an
ensemble of several members, and evaluates a single modular SNN and the ensemble,
each without and with sequence matching, next to SAD on the same images. The model is
found through its entry point (``neurovpr.models``: ``modular``), like any plug-in.
Prints one table and writes ``summary.json`` and the PNG plots to the report folder.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from neurovpr.apps.modelapi import get_model, read_run_info
from neurovpr.errors import ValidationError
from neurovpr.fileio import atomic_write_text

#: The query traverse's look (see :class:`neurovpr.data.synthetic.AppearanceChange`).
_QUERY_LOOK_ARGS = {"season": 0.5, "illumination": 0.7, "contrast": 0.8, "blur_sigma": 0.6, "shift_px": 2, "noise_std": 0.03}
_LIMITS = {"places": (4, 200), "module_size": (2, 100), "members": (1, 10), "epochs": (1, 60), "seq_len": (2, 20)}


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser("demo", help="train and evaluate the Modular SNN on a small synthetic route")
    p.add_argument("--out", type=Path, default=Path("reports/demo"), help="report folder (default: reports/demo)")
    p.add_argument("--backend", default="reference", help="backend to run on (default: reference)")
    p.add_argument("--places", type=int, default=30, help="places on the synthetic route (default 30)")
    p.add_argument("--module-size", type=int, default=15, help="places per module (default 15)")
    p.add_argument("--members", type=int, default=3, help="ensemble members (default 3)")
    p.add_argument("--epochs", type=int, default=8, help="training epochs per module (default 8)")
    p.add_argument("--seq-len", type=int, default=4, help="sequence length of sequence matching (default 4)")
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: the CPU cores)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(handler=run)


def _check(args: argparse.Namespace) -> None:
    for name, (low, high) in _LIMITS.items():
        value = getattr(args, name)
        if not low <= value <= high:
            raise ValidationError(f"demo: --{name.replace('_', '-')} must be in {low}..{high}, got {value}.")
    if args.seq_len > args.places:
        raise ValidationError(f"demo: --seq-len {args.seq_len} is longer than the route ({args.places} places).")


def run(args: argparse.Namespace) -> int:
    """Train, evaluate and report."""
    _check(args)
    from neurovpr.data.generic import write_generic
    from neurovpr.data.synthetic import AppearanceChange, synthetic_traverse

    model = get_model("modular")
    query_look = AppearanceChange(**_QUERY_LOOK_ARGS)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="neurovpr-demo-") as tmp:
        data, run_dir = Path(tmp) / "data", Path(tmp) / "run"
        write_generic(synthetic_traverse(args.places, seed=args.seed, query=query_look), data)
        trained = model.train(
            data=data, out=run_dir, backend=args.backend, seed=args.seed,
            members=args.members, epochs=args.epochs, module_size=args.module_size, workers=args.workers,
        )  # fmt: skip
        info = read_run_info(run_dir)
        results = {
            seq_len: model.evaluate(run=run_dir, backend=args.backend, seq_len=seq_len, report=args.out, run_info=info)
            for seq_len in (1, args.seq_len)
        }
        hardware = _hardware_rows(sorted((run_dir / "modules").glob("*.h5"))[0], args.out)
    elapsed = time.perf_counter() - start
    summary = _summary(args, trained, results, elapsed)
    summary["hardware"] = hardware
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / "summary.json", json.dumps(summary, indent=2))
    if args.json:
        print(json.dumps(summary))
    else:
        _print_table(summary)
    return 0


def _hardware_rows(module_file: Path, out: Path) -> list[dict[str, Any]]:
    """Fit check and energy of one trained module on every hwspec (one query's activity, reference backend)."""
    import numpy as np

    import neurovpr as nv
    from neurovpr.hardware import check_network, estimate_energy, known_hwspecs
    from neurovpr.hardware.plots import plot_utilisation

    net = nv.load(module_file)
    dt = 0.1  # the module's time step (its input delays start at 0.1 ms)
    sim = nv.compile(net, backend="reference", dt=dt, seed=0, record_spikes=())
    sim.plasticity(False)
    rates = np.random.default_rng(0).uniform(0.0, 63.75, net.populations["pixels"].size)
    sim.run(350.0, inputs={"pixels": rates})
    activity = dict(sim.statistics(), inferences=1, dt_ms=dt)
    rows = []
    for hw in known_hwspecs():
        report = check_network(net, hw)
        energy = estimate_energy(activity, hw, network=net, partition=report.partition)
        d = report.as_dict()
        plot_utilisation(report, out / f"utilisation_{hw}.png")
        rows.append(
            {
                "hardware": hw,
                "fits": d["fits"],
                "chips": d["chips"],
                "cores": d["cores"],
                "violations": len(d["violations"]),
                "joules_per_inference": energy.joules_per_inference,
            }
        )
    return rows


def _summary(args: argparse.Namespace, trained: dict[str, Any], results: dict[int, Any], elapsed: float) -> dict[str, Any]:
    rows: dict[str, dict[str, float]] = {"Modular SNN": {}, f"Ensemble ({args.members})": {}, "SAD": {}}
    for seq_len, res in results.items():
        key = f"R@1 L={seq_len}"
        rows["Modular SNN"][key] = res["modular_snn"]["R@1"]
        rows[f"Ensemble ({args.members})"][key] = res["metrics"]["R@1"]
        rows["SAD"][key] = res["baselines"]["SAD"]["R@1"]
    last = results[args.seq_len]
    return {
        "model": "modular",
        "backend": args.backend,
        "data": f"synthetic route, {args.places} places, seed {args.seed} (summer reference, late-autumn query)",
        "plan": trained.get("plan"),
        "members": args.members,
        "epochs": args.epochs,
        "seq_lens": [1, args.seq_len],
        "R@1": rows,
        "mean_of_members_R@1": {f"L={k}": v["mean_of_members"]["R@1"] for k, v in results.items()},
        "train_seconds_per_module": trained.get("train_seconds_per_module"),
        "total_seconds": round(elapsed, 1),
        "report": str(args.out),
        "files": sorted({Path(f).name for res in results.values() for f in res["files"].values()}),
        "metrics": {"ensemble": last["metrics"], "modular_snn": last["modular_snn"], "SAD": last["baselines"]["SAD"]},
    }


def _print_table(summary: dict[str, Any]) -> None:
    out = sys.stdout
    print(f"Modular SNN demo on the {summary['backend']} backend: {summary['data']}", file=out)
    print(f"  {summary['plan']}; {summary['members']} ensemble members; {summary['epochs']} epochs", file=out)
    cols = [f"R@1 L={n}" for n in summary["seq_lens"]]
    print(f"  {'method':<16}" + "".join(f"{c:>12}" for c in cols), file=out)
    for name, values in summary["R@1"].items():
        print(f"  {name:<16}" + "".join(f"{values[c]:>12.3f}" for c in cols), file=out)
    mean = summary["mean_of_members_R@1"]
    print("  (mean of the members: " + ", ".join(f"{k} {v:.3f}" for k, v in mean.items()) + ")", file=out)
    print("  one module on neuromorphic hardware (fit check, energy of one query):", file=out)
    for row in summary.get("hardware", []):
        fits = "fits" if row["fits"] else f"does not fit ({row['violations']} violations)"
        print(
            f"    {row['hardware']:<11} {row['cores']:>4} cores {row['chips']:>2} chip(s)  {fits:<28}"
            f" {row['joules_per_inference']:.3g} J",
            file=out,
        )
    print(
        f"  training {summary['train_seconds_per_module']} s per module; total {summary['total_seconds']} s; "
        f"report written to {summary['report']}",
        file=out,
    )
