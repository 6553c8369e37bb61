"""Fit and energy of the three papers' models at their published sizes on every hwspec.

Prints, for each model and each hardware target, whether it fits, the chips and cores
the vendor-style partition needs, the violated limits, and the estimated energy of
one inference from the activity of one reference-simulator run (random, untrained
weights: indicative only). The networks are those of tests/hardware/hw_models.py:
Modular SNN (one module and 123 modules = 3,072 Nordland places / 25), MBSNN (840
PNs, 2 x 4000 KC compartments, 1 MBON) and LoCS-Net (56x56 -> 3x3 stride-2 convs of
8/16/32 channels -> 3,072 places). MBSNN is also checked on SpiNN-5 at its simulation step
of 0.1 ms, where sPyNNaker gives every population with input separate neuron and
synapse cores.

Usage::

    python benchmarks/hardware_papers.py [--json OUT] [--hw NAME,NAME,...]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

import neurovpr as nv
from neurovpr.hardware import check_network, estimate_energy, known_hwspecs, read_activity, write_activity

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "hardware"))
from hw_models import locsnet, mbsnn, modular_snn


def _activity(name: str, net: nv.Network, folder: Path, dt: float = 1.0) -> dict:
    """One inference on the reference simulator at ``dt`` ms steps, saved and read back as activity."""
    rng = np.random.default_rng(0)
    if name.startswith("modular"):
        duration = 350.0
        inputs = {p: rng.uniform(0.0, 63.75, 784) for p in net.populations if p.endswith("pixels")}
    elif name.startswith("mbsnn"):
        duration, inputs = 100.0, {}
    else:
        duration, inputs = 100.0, {"input": rng.uniform(0.0, 100.0, 56 * 56)}
    sim = nv.compile(net, backend="reference", dt=dt, seed=1, record_spikes=())
    sim.run(duration, inputs=inputs)
    spikes = {p: int(sim.spike_counts(p).sum()) for p in net.populations}
    write_activity(folder, sim.statistics(), 1, dt_ms=dt, population_spikes=spikes)
    return read_activity(folder)


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--hw", default=None, help="comma-separated hwspecs (default: every shipped one)")
    args = parser.parse_args()
    chosen = set(args.hw.split(",")) if args.hw else None
    models = {  # name: (builder, time step in ms, hwspecs)
        "modular (1 module)": (lambda: modular_snn(1, plastic=False), 1.0, known_hwspecs()),
        "modular (123 modules)": (lambda: modular_snn(123, plastic=False), 1.0, known_hwspecs()),
        "mbsnn": (mbsnn, 1.0, known_hwspecs()),
        "mbsnn (dt 0.1 ms)": (mbsnn, 0.1, ("spinn5",)),
        "locsnet": (locsnet, 1.0, known_hwspecs()),
    }
    rows = []
    for name, (build, dt, hwspecs) in models.items():
        hwspecs = [hw for hw in hwspecs if chosen is None or hw in chosen]
        if not hwspecs:
            continue
        net = build()
        with tempfile.TemporaryDirectory() as tmp:
            activity = _activity(name, net, Path(tmp), dt)
        for hw in hwspecs:
            report = check_network(net, hw, dt=dt)
            energy = estimate_energy(activity, hw, network=net, partition=report.partition)
            d = report.as_dict()
            rows.append(
                {
                    "model": name,
                    "hardware": hw,
                    "dt_ms": dt,
                    "fits": d["fits"],
                    "chips": d["chips"],
                    "cores": d["cores"],
                    "violations": [v if isinstance(v, str) else v.get("limit", str(v)) for v in d["violations"]],
                    "joules_per_inference": energy.joules_per_inference,
                }
            )
            joules = energy.joules_per_inference
            shown = "not estimated" if joules is None else f"{joules:.4g} J"
            print(
                f"{name:22s} {hw:11s} fits={'yes' if d['fits'] else 'no ':3s} chips={d['chips']:3d} cores={d['cores']:4d}"
                f" energy={shown}  violations={len(d['violations'])}"
                f" {sorted({v['limit'] for v in d['violations']})}"
            )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2, default=str))


if __name__ == "__main__":
    main()
