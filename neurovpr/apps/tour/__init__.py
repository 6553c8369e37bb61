"""``neurovpr demo``: a short tour of what neurovpr is for, written as one HTML report.

1. one network declared once and run on every installed backend (:mod:`.backends_part`);
2. fit checks: the MBSNN at its paper size on SpiNN-5, a trained LoCS-Net on Kapoho Bay,
   and the MBSNN on Kapoho Bay, which does not fit, with what would make it fit (:mod:`.fit_part`);
3. off- vs on-chip accuracy and energy of the trained LoCS-Net (:mod:`.onchip_part`);
4. the Modular SNN next to SAD (:mod:`.modular_part`).

Everything runs on embedded data: the synthetic route of :mod:`neurovpr.data.synthetic`
(summer reference, late-autumn query) and synthetic projection-neuron spikes for the
mushroom body. The models are reached only through their plug-ins
(``from neurovpr import models``). :class:`TourSize` holds every size; ``TourSize.tiny()``
is the one the default test run uses.
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr import models
from neurovpr.apps.rundir import RunDir
from neurovpr.fileio import atomic_write_text

from .backends_part import TOUR_BACKENDS, run_backends
from .fit_part import fit_check
from .modular_part import run_modular
from .onchip_part import ONCHIP_BACKENDS, query_subset, run_onchip, train_locsnet
from .report import plot_backends, write_html

__all__ = ["TourSize", "run_tour"]

#: The query traverse's look (see :class:`neurovpr.data.synthetic.AppearanceChange`).
QUERY_LOOK = {"season": 0.5, "illumination": 0.7, "contrast": 0.8, "blur_sigma": 0.6, "shift_px": 2, "noise_std": 0.03}


@dataclass(frozen=True, slots=True, kw_only=True)
class TourSize:
    """Every size of the tour (the defaults are the full demo)."""

    places: int = 30
    backend_ms: float = 1000.0
    n_pn: int = 840
    n_kc: int = 4000
    kc_groups: int = 4
    recording_ms: float = 1000.0
    locsnet_epochs: int = 40
    onchip_queries: int = 8
    modular_members: int = 1
    modular_epochs: int = 8
    module_size: int = 15
    modular_neurons: int = 400
    seq_len: int = 4

    @classmethod
    def tiny(cls) -> TourSize:
        """The smallest tour that still has every part (about a minute; for tests)."""
        return cls(places=6, backend_ms=100.0, n_pn=84, n_kc=200, kc_groups=1, recording_ms=300.0, locsnet_epochs=2,
                   onchip_queries=2, modular_epochs=1, module_size=3, modular_neurons=20, seq_len=2)  # fmt: skip


def _pn_recording(path: Path, size: TourSize, seed: int) -> Path:
    """Write synthetic projection-neuron spikes (MATLAB ``t``/``idx``, 1-ms bins) of a route of distinct places.

    Every 50 ms the route reaches a new place, seen as its own random 10 % of the PNs
    firing in a volley every 2 ms, with 10 % of the spikes lost.
    """
    import scipy.io

    rng = np.random.default_rng(seed)
    times, idx = [], []
    for start in np.arange(0.0, size.recording_ms, 50.0):
        group = rng.choice(size.n_pn, size=max(1, size.n_pn // 10), replace=False)
        for t in np.arange(start, min(start + 50.0, size.recording_ms), 2.0):
            keep = group[rng.random(group.size) > 0.1]
            times.append(np.full(keep.size, t))
            idx.append(keep)
    t_all, i_all = np.concatenate(times), np.concatenate(idx)
    scipy.io.savemat(path, {"t": t_all[:, None], "idx": i_all.astype(float)[:, None]})
    return path


def _mbsnn_network(folder: Path, size: TourSize, seed: int) -> Any:
    """The mushroom body at ``size`` (the paper's 840 PNs and 4000 KCs by default), trained through its plug-in."""
    recording = _pn_recording(folder / "route_pn.mat", size, seed)
    models.get("mbsnn").train(
        data=recording, out=folder / "mbsnn", seed=seed, progress=False,
        n_kc=size.n_kc, kc_groups=size.kc_groups, n_pn=size.n_pn, timestep=1.0, keep_still=True,
    )  # fmt: skip
    return RunDir(folder / "mbsnn").load_network()


def _machine() -> str:
    return f"{os.cpu_count()} {platform.machine()} cores ({platform.system()})"


def run_tour(
    out: Path, *, size: TourSize | None = None, seed: int = 1, workers: int | None = None, log: Any = None,
    backends: tuple[str, ...] = TOUR_BACKENDS, onchip_backends: tuple[str, ...] = ONCHIP_BACKENDS,
) -> dict[str, Any]:
    """Run the four parts, write ``out/report.html``, ``out/summary.json`` and the PNGs; returns the summary.

    ``backends`` and ``onchip_backends`` choose the backends of parts 1 and 3 (the first
    that runs is the reference of comparison); ``log`` receives one line per part.
    """
    from neurovpr.data.generic import write_generic
    from neurovpr.data.synthetic import AppearanceChange, synthetic_traverse

    size = size or TourSize()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    say = log or (lambda text: None)
    start = time.perf_counter()
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="neurovpr-tour-") as tmp_name:
        tmp = Path(tmp_name)
        data = tmp / "route"
        look = AppearanceChange(**QUERY_LOOK)
        write_generic(synthetic_traverse(size.places, seed=seed, query=look), data)

        say("1/4 one network on every backend")
        t = time.perf_counter()
        part1 = run_backends(size.backend_ms, backends=backends)
        part1["plot"] = plot_backends(part1, out / "backends.png").name
        seconds["backends"] = time.perf_counter() - t

        say("2/4 fit checks (training the mushroom body and LoCS-Net)")
        t = time.perf_counter()
        mbsnn = _mbsnn_network(tmp, size, seed)
        locsnet_run = tmp / "locsnet"
        train_locsnet(data, locsnet_run, epochs=size.locsnet_epochs, seed=seed)
        locsnet = RunDir(locsnet_run).load_network()
        fit = [
            fit_check(mbsnn, "spinn5", out, dt=1.0, label="mbsnn_spinn5"),
            fit_check(locsnet, "kapoho-bay", out, dt=1.0, label="locsnet_kapoho-bay"),
            fit_check(mbsnn, "kapoho-bay", out, dt=1.0, label="mbsnn_kapoho-bay"),
        ]
        seconds["fit"] = time.perf_counter() - t

        say("3/4 off-chip vs on-chip (LoCS-Net on the reference backend, NengoLoihi and Lava fixed point)")
        t = time.perf_counter()
        onchip = run_onchip(locsnet_run, query_subset(data, tmp / "onchip_route", size.onchip_queries), out,
                            backends=onchip_backends)
        onchip["about"] = (
            f"LoCS-Net (the paper's layer sizes, {size.places} places, {size.locsnet_epochs} epochs of torch training on "
            f"the summer traverse, regular-rate input coding), queried with {size.onchip_queries} evenly spaced "
            "places of the late-autumn traverse (the emulated chips take seconds per query here). The energy is "
            "the chip's estimate from each backend's own activity counts; at this size static power dominates it."
        )
        seconds["onchip"] = time.perf_counter() - t

        say("4/4 the Modular SNN next to SAD (training in worker processes)")
        t = time.perf_counter()
        modular = run_modular(
            data, tmp / "modular", out, members=size.modular_members, epochs=size.modular_epochs,
            module_size=size.module_size, neurons=size.modular_neurons, seq_len=size.seq_len, seed=seed, workers=workers,
        )  # fmt: skip
        seconds["modular"] = time.perf_counter() - t

    summary = {
        "data": f"synthetic route, {size.places} places, seed {seed} (summer reference, late-autumn query)",
        "size": dataclasses.asdict(size),
        "machine": _machine(),
        "backends": part1,
        "fit": fit,
        "onchip": onchip,
        "modular": modular,
        "seconds": {k: round(v, 1) for k, v in seconds.items()},
        "total_seconds": round(time.perf_counter() - start, 1),
    }
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2))
    summary["report"] = str(write_html(summary, out))
    return summary
