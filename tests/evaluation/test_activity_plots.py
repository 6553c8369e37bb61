"""Spike rasters and rate histograms of any simulation: PNG files whose titles fit, and a JSON summary."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import neurovpr as nv
from neurovpr.errors import ValidationError
from neurovpr.evaluation.activity_plots import RASTER_FILE, RATES_FILE, SUMMARY_FILE, plot_rate_histograms


def _sim() -> nv.Simulation:
    net = nv.Network("raster-net")
    net.add_population("inp", 10, nv.SpikeSourcePoisson(rate=80.0))
    net.add_population("exc", 6, nv.IF_curr_exp(tau_refrac=1.0))
    net.connect("inp", "exc", nv.AllToAllConnector(), nv.StaticSynapse(weight=1.5))
    sim = nv.compile(net, backend="reference", dt=0.5, seed=2)
    sim.run(200.0)
    return sim


def _title_fits(png: Path) -> None:
    """The top rows hold dark title pixels, and none touch the image's edges (nothing clipped)."""
    from PIL import Image

    img = np.asarray(Image.open(png).convert("L"), dtype=np.int32)
    dark = img < 128
    assert dark[: img.shape[0] // 8].any(), f"{png.name}: no title at the top"
    assert not dark[0].any() and not dark[:, 0].any() and not dark[:, -1].any(), f"{png.name}: drawing touches the edge"


def test_sim_helper_writes_raster_rates_and_summary(tmp_path: Path) -> None:
    sim = _sim()
    paths = sim.plot_activity(tmp_path / "plots")
    assert paths["raster"].name == RASTER_FILE and paths["rates"].name == RATES_FILE
    for key in ("raster", "rates"):
        assert paths[key].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        _title_fits(paths[key])
    summary = json.loads((tmp_path / "plots" / SUMMARY_FILE).read_text())
    for pop in ("inp", "exc"):
        entry = summary["populations"][pop]
        assert entry["spikes"] == int(sim.spike_counts(pop).sum()) > 0
        assert entry["mean_rate_hz"] == pytest.approx(sim.spike_counts(pop).mean() * 1000.0 / 200.0)
    assert summary["populations"]["inp"]["mean_rate_hz"] == pytest.approx(80.0, rel=0.3)


def test_refusals(tmp_path: Path) -> None:
    sim = _sim()
    with pytest.raises(ValidationError, match="'nope'"):
        sim.plot_activity(tmp_path, populations=["nope"])
    sim.reset()
    with pytest.raises(ValidationError, match="not run"):
        sim.plot_activity(tmp_path)
    with pytest.raises(ValidationError, match=r"\.png"):
        plot_rate_histograms({"a": np.ones(3)}, tmp_path / "r.jpg")
    assert not list(tmp_path.iterdir())


def test_energy_cli_plots_flag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from neurovpr.cli.main import main

    net = nv.Network("probe")
    net.add_population("inp", 8, nv.SpikeSourcePoisson(rate=0.0))
    net.add_population("out", 4, nv.IF_curr_exp())
    net.connect("inp", "out", nv.AllToAllConnector(), nv.StaticSynapse(weight=2.0))
    nv.save(net, tmp_path / "net.h5")
    args = ["energy", "--file", str(tmp_path / "net.h5"), "--hw", "loihi2", "--rate", "100", "--plots", str(tmp_path / "p")]
    assert main(args) == 0
    assert (tmp_path / "p" / RASTER_FILE).is_file() and (tmp_path / "p" / RATES_FILE).is_file()
    capsys.readouterr()
    assert main(["energy", "--run", str(tmp_path), "--hw", "loihi2", "--plots", str(tmp_path / "q")]) == 2
    assert "--plots" in capsys.readouterr().err and not (tmp_path / "q").exists()
