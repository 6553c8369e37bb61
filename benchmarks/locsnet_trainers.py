"""LoCS-Net trained with torch and with NengoDL on the same data: accuracy and spikes after conversion.

Both trainers (``neurovpr train --model locsnet --trainer torch|nengo-dl``) train the same
architecture with the same hyper-parameters on the same reference images; each run is
converted to the same spiking network form, calibrated on the same training images and
evaluated (``neurovpr eval``) on the same queries and backend. Printed per trainer:
training time, final training accuracy, Recall@1 of the spiking network and of its rate
model on the queries, and the mean spikes per layer per query of the spiking network.

Data: a synthetic route (``neurovpr.data.synthetic``, the default) or a folder in the
generic layout, of which the first ``--places`` reference/query pairs are used (e.g.
``../shared/datasets/nordland64``: summer reference, winter query, query i is place i).

Usage (from the repository root)::

    python benchmarks/locsnet_trainers.py [--data synthetic|PATH] [--places 40] [--epochs 30]
        [--trainer torch,nengo-dl] [--preset small] [--backend reference] [--out reports/locsnet_trainers]

Writes ``results.json`` and the two run directories to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path
from typing import Any


def _dataset(data: str, places: int, folder: Path, seed: int) -> Path:
    """The generic-layout folder to train on: a synthetic route, or the first ``places`` pairs of ``data``."""
    from neurovpr.data import synthetic_traverse, write_generic

    if data == "synthetic":
        return write_generic(synthetic_traverse(places, seed=seed), folder / "synthetic", overwrite=True)
    source = Path(data)
    out = folder / f"{source.name}-{places}"
    for part in ("reference", "query"):
        files = sorted(p for p in (source / part).iterdir() if p.is_file())[:places]
        if len(files) < places:
            raise SystemExit(f"{source / part} has {len(files)} images, fewer than --places {places}.")
        (out / part).mkdir(parents=True, exist_ok=True)
        for f in files:
            if not (out / part / f.name).exists():
                shutil.copyfile(f, out / part / f.name)
    return out


def _one(trainer: str, data: Path, out: Path, args: argparse.Namespace) -> dict[str, Any]:
    from neurovpr import models

    model = models.get("locsnet")
    run = out / trainer
    if run.exists():
        shutil.rmtree(run)
    t0 = time.perf_counter()
    summary = model.train(
        data=data,
        out=run,
        trainer=trainer,
        preset=args.preset,
        epochs=args.epochs,
        batch_size=args.batch_size,
        seed=args.seed,
        calibration_images=args.calibration_images,
        input_coding="regular",
        threads=1,
    )
    t_train = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = model.evaluate(run=run, backend=args.backend, no_plots=True)
    t_eval = time.perf_counter() - t0
    return {
        "trainer": trainer,
        "train_seconds": summary["train_seconds"],
        "train_total_seconds": t_train,
        "train_accuracy": summary["train_accuracy"],
        "spiking_R@1": result["metrics"]["R@1"],
        "spiking_R@5": result["metrics"]["R@5"],
        "rate_R@1": result["rate_model"]["R@1"],
        "SAD_R@1": result["baselines"]["SAD"]["R@1"],
        "layer_spikes_per_query": result["layer_spikes_per_query"],
        "eval_seconds": t_eval,
        "queries": result["queries"],
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", default="synthetic", help="'synthetic' or a generic-layout folder")
    p.add_argument("--places", type=int, default=40)
    p.add_argument("--epochs", type=int, default=30)
    p.add_argument("--batch-size", type=int, default=16)
    p.add_argument("--calibration-images", type=int, default=40)
    p.add_argument("--preset", choices=("small", "paper"), default="small")
    p.add_argument("--trainer", default="torch,nengo-dl", help="comma-separated trainers (default torch,nengo-dl)")
    p.add_argument("--backend", default="reference", help="backend the spiking networks are evaluated on")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("reports/locsnet_trainers"))
    args = p.parse_args(argv)

    args.out.mkdir(parents=True, exist_ok=True)
    data = _dataset(args.data, args.places, args.out / "data", args.seed)
    trainers = [t.strip() for t in args.trainer.split(",") if t.strip()]
    print(
        f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}; data {args.data} "
        f"({args.places} places), preset {args.preset}, {args.epochs} epochs, batch {args.batch_size}",
        flush=True,
    )
    rows = [_one(trainer, data, args.out, args) for trainer in trainers]
    layers = list(rows[0]["layer_spikes_per_query"])
    print(
        f"{'trainer':<10} {'train s':>8} {'train acc':>9} {'R@1 spk':>8} {'R@1 rate':>8} {'R@1 SAD':>8}  "
        + "  ".join(f"{name:>9}" for name in layers)
    )
    for r in rows:
        print(
            f"{r['trainer']:<10} {r['train_seconds']:8.1f} {r['train_accuracy']:9.3f} {r['spiking_R@1']:8.3f} "
            f"{r['rate_R@1']:8.3f} {r['SAD_R@1']:8.3f}  "
            + "  ".join(f"{r['layer_spikes_per_query'].get(name, 0.0):9.1f}" for name in layers)
        )
    record = {
        "data": args.data,
        "places": args.places,
        "preset": args.preset,
        "epochs": args.epochs,
        "batch_size": args.batch_size,
        "backend": args.backend,
        "runs": rows,
        "load_average": os.getloadavg()[0],
    }
    (args.out / "results.json").write_text(json.dumps(record, indent=2), encoding="utf-8")
    print(f"wrote {args.out / 'results.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
