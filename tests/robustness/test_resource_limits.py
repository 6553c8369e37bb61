"""Networks with too many populations and model options past the memory limit are refused before any work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.io

import neurovpr as nv
from neurovpr.data.events import PNSpikes
from neurovpr.hardware import check_network
from neurovpr.resources import DEFAULT_MAX_NODES, ResourceLimitError


def _many(n: int) -> nv.Network:
    net = nv.Network("many")
    net.add_population("src", 1, nv.SpikeSourcePoisson(rate=20.0))
    for i in range(n):
        net.add_population(f"p{i}", 1, nv.IF_curr_exp())
    return net


@pytest.fixture
def many_file(tmp_path: Path) -> Path:
    path = tmp_path / "many.h5"
    nv.save(_many(60), path)
    return path


@pytest.mark.parametrize("command", ["energy", "check"])
def test_a_file_with_too_many_populations_is_refused_before_decoding(command, many_file, monkeypatch, cli_refused) -> None:
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "50")
    cli_refused(
        [command, "--file", str(many_file), "--hw", "spinn5"],
        f"Network file {str(many_file)!r} holds 61 populations and 0 projections (61 in all); "
        "the limit is 50 (NEUROVPR_MAX_NODES).",
    )
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "100")
    assert len(nv.load(many_file).populations) == 61


def test_compile_and_check_refuse_a_network_with_too_many_populations(monkeypatch) -> None:
    net = _many(60)
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "50")
    with pytest.raises(ResourceLimitError, match=r"compile: network 'many' holds 61 populations .* the limit is 50"):
        nv.compile(net, backend="reference")
    with pytest.raises(ResourceLimitError, match=r"check: network 'many' holds 61 populations"):
        check_network(net, "spinn5")
    monkeypatch.setenv("NEUROVPR_MAX_NODES", "lots")
    with pytest.raises(nv.ValidationError, match=r"NEUROVPR_MAX_NODES='lots' must be a positive whole number"):
        nv.compile(net, backend="reference")


def test_the_default_node_limit_names_its_variable() -> None:
    with pytest.raises(ResourceLimitError, match=rf"the limit is {DEFAULT_MAX_NODES} \(the default; set NEUROVPR_MAX_NODES"):
        nv.compile(_many(DEFAULT_MAX_NODES), backend="reference")


def test_mbsnn_train_refuses_a_mushroom_body_past_the_memory_limit_before_reading_data(tmp_path, monkeypatch, cli_refused):
    missing = tmp_path / "never-read.mat"  # the options are refused before the data is looked at
    base = ["train", "--model", "mbsnn", "--data", str(missing), "--out", str(tmp_path / "o")]
    line = cli_refused(
        [*base, "--n-kc", "4000000", "--kc-groups", "1"],
        "train: the mushroom body with 4000000 Kenyon cells in 1 subgroup(s) and PNs from the data needs about",
    )
    assert "to draw its wiring; the limit is" in line and "NEUROVPR_MAX_MEMORY" in line
    cli_refused([*base, "--n-pn", "100000000"], "and 100000000 PNs needs about")
    monkeypatch.setenv("NEUROVPR_MAX_MEMORY", "1G")
    line = cli_refused([*base, "--n-kc", "40000", "--kc-groups", "40"], "needs about")
    assert "of it to draw the wiring); the limit is 1.0 GiB (NEUROVPR_MAX_MEMORY)." in line
    cli_refused(base, "does not exist")  # the paper's sizes pass the estimate
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("options", "pattern"),
    [
        (["--batch-size", "1000000000"], "train: LoCS-Net training batches of 1000000000 images (--batch-size)"),
        (
            ["--presentation", "1000000000", "--dt", "1"],
            "train: LoCS-Net's spiking calibration on 100 images (--calibration-images) of 1000000000 steps each",
        ),
    ],
)
def test_locsnet_train_refuses_options_past_the_limits_before_reading_data(options, pattern, tmp_path, cli_refused):
    argv = ["train", "--model", "locsnet", "--data", str(tmp_path / "never-read"), "--out", str(tmp_path / "o")]
    line = cli_refused([*argv, *options], pattern)
    assert "the limit is" in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("times", "pattern"),
    [
        ([0.0, 5.0, 1e12], "the learned segment 0.4:0.6 of"),  # trimmed without counting 10^10 windows
        ([0.0, 5.0, 4.5e11, 1e12], "mbsnn: 2e+11 ms of PN spikes: 2e+12 steps of 0.1 ms of network 'mbsnn' needs about"),
    ],
)
def test_mbsnn_train_refuses_a_mat_recording_of_1e12_ms(times, pattern, tmp_path, cli_refused) -> None:
    path = tmp_path / "long.mat"
    scipy.io.savemat(path, {"t": np.array(times), "idx": np.arange(len(times), dtype=float) % 3})
    cli_refused(["train", "--model", "mbsnn", "--data", str(path), "--out", str(tmp_path / "o")], pattern)
    assert not (tmp_path / "o").exists()


def test_active_interval_counts_only_windows_that_hold_spikes() -> None:
    rng = np.random.default_rng(7)
    for _ in range(50):
        times = np.sort(rng.choice(rng.integers(5, 200), size=rng.integers(1, 40)) * 10.0 + rng.random())
        spikes = PNSpikes(times_ms=times, idx=np.zeros(times.size, np.int64), n_pn=1, duration_ms=float(times[-1]) + 1)
        n_windows = max(int(np.ceil(spikes.duration_ms / 100.0)), 1)
        counts = np.bincount(np.minimum((times // 100.0).astype(np.int64), n_windows - 1), minlength=n_windows)
        active = np.flatnonzero(counts >= max(0.25 * np.percentile(counts, 75), 1))
        expected = (float(active[0] * 100.0), float(min((active[-1] + 1) * 100.0, spikes.duration_ms)))
        assert spikes.active_interval() == expected
    far = PNSpikes(times_ms=np.array([0.0, 1e12]), idx=np.zeros(2, np.int64), n_pn=1, duration_ms=1e12 + 1)
    assert far.active_interval() == (0.0, 1e12 + 1)
