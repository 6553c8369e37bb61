"""The command line refuses bad arguments and output paths before any work: exit 2, one line, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import neurovpr as nv
from neurovpr.fileio import is_temp_name


@pytest.fixture(scope="module")
def network_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    net = nv.Network("n")
    net.add_population("s", 4, nv.SpikeSourcePoisson(rate=10.0))
    net.add_population("a", 3, nv.IF_curr_exp(tau_refrac=0.0))
    net.connect("s", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1))
    path = tmp_path_factory.mktemp("net") / "net.h5"
    nv.save(net, path)
    return path


_SEED_COMMANDS = [
    ["train", "--model", "modular", "--data", "DATA", "--out", "OUT"],
    ["demo", "--out", "OUT"],
    ["energy", "--file", "NET", "--hw", "spinn5"],
    ["check", "--file", "NET", "--hw", "spinn5"],
    ["compare", "--run", "OUT", "--data", "DATA", "--backends", "reference"],
    ["export", "--file", "NET", "--format", "nir", "--out", "OUT/x.nir"],
]


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    command=st.sampled_from(_SEED_COMMANDS),
    seed=st.one_of(st.integers(max_value=-1), st.integers(min_value=2**63)),
)
def test_seeds_out_of_range_are_refused(command, seed, network_file, tmp_path, cli_refused) -> None:
    argv = [
        a.replace("NET", str(network_file)).replace("OUT", str(tmp_path / "o")).replace("DATA", str(tmp_path)) for a in command
    ]
    cli_refused([*argv, "--seed", str(seed)], f"--seed is {seed}; it must be an integer >= 0 and <= 2**63 - 1")
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("argv", "pattern"),
    [
        (["eval", "--run", "RUN", "--seq-len", "0"], "--seq-len is 0; it must be an integer >= 1"),
        (["train", "--model", "modular", "--data", "RUN", "--out", "RUN/o", "--workers", "0"], "--workers is 0"),
        (["train", "--model", "modular", "--data", "RUN", "--out", "RUN/o", "--workers", "-3"], "--workers is -3"),
        (["demo", "--out", "RUN/o", "--workers", "0"], "--workers is 0"),
        (
            ["train", "--model", "mbsnn", "--data", "RUN", "--out", "RUN/o", "--neurons", "10"],
            "--neurons does not apply to model 'mbsnn' (neurovpr train --model mbsnn --help lists its options)",
        ),
        (["energy", "--file", "NET", "--hw", "spinn5", "--duration", "nan"], "--duration is nan"),
        (
            ["energy", "--file", "NET", "--hw", "spinn5", "--duration", "1e12"],
            "--duration is 1e+12; it must be a number > 0 and <= 1e+09 ms",
        ),
        (["energy", "--run", "RUN", "--hw", "spinn5", "--rate", "5"], "--rate applies only with --file"),
        (["check", "--file", "NET", "--hw", "spinn5", "--plot", "RUN/p.txt"], "--plot 'RUN/p.txt' must end in .png"),
        (["check", "--file", "NET", "--hw", "spinn5", "--plot", "NET/p.png"], "is a file, not a folder"),
        (
            ["compare", "--run", "RUN", "--data", "RUN", "--backends", "reference", "--plot", "RUN"],
            "--plot 'RUN' must end in .png",
        ),
        (["demo", "--out", "NET"], "--out 'NET' is an existing file; give a folder"),
        (["train", "--model", "modular", "--data", "RUN", "--out", "NET"], "--out 'NET' is an existing file; give a folder"),
        (["eval", "--run", "RUN", "--report", "NET"], ""),
        (["export", "--file", "NET", "--format", "nir", "--out", "NET"], "is the same file as the input"),
        (["export", "--file", "NET", "--format", "nir", "--out", "RUN"], "--out 'RUN' is a folder; give a file name"),
        (["import", "NET", "--out", "NET"], "is the same file as the input"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(argv, pattern, network_file, tmp_path, cli_refused) -> None:
    def fill(text: str) -> str:
        return text.replace("NET", str(network_file)).replace("RUN", str(tmp_path))

    before = network_file.read_bytes()
    cli_refused([fill(a) for a in argv], fill(pattern))
    assert network_file.read_bytes() == before
    assert not (tmp_path / "o").exists()
    assert not [p for p in tmp_path.rglob("*") if is_temp_name(p.name)]


def test_eval_checks_the_run_model_options(tmp_path, cli_refused) -> None:
    (tmp_path / "run.json").write_text('{"model": "mbsnn", "backend": "reference", "seed": 0}')
    run = ["eval", "--run", str(tmp_path)]
    cli_refused([*run, "--windows", "1000000000"], "--windows is 1000000000; it must be an integer >= 1 and <= 1e+06")
    cli_refused([*run, "--neurons", "5"], "--neurons does not apply to model 'mbsnn' (neurovpr eval --run RUN_DIR --help")


def test_train_refuses_a_module_past_the_memory_limit(tmp_path, cli_refused) -> None:
    line = cli_refused(
        [
            "train",
            "--model",
            "modular",
            "--data",
            str(tmp_path),
            "--out",
            str(tmp_path / "o"),
            "--neurons",
            "100000",
            "--workers",
            "2",
        ],
        "train: network 'modular_snn_module' x 2 at once needs about",
    )
    assert "projection 'lateral'" in line and "NEUROVPR_MAX_MEMORY" in line
