"""``neurovpr check``: does a network fit a hardware target? Exit 0 if it fits, 1 if not."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from neurovpr.apps.rundir import RunDir
from neurovpr.errors import ValidationError
from neurovpr.ir.network import Network


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "check",
        help="check that a network fits a hardware target (exit 1 if it does not)",
        description=(
            "Partition a network onto a hardware target with the vendor toolchain's rules and report per-core "
            "utilisation and every broken limit. Exit 0 if it fits, 1 if not, 2 on bad input."
        ),
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--run", metavar="RUN_DIR", help="a run directory holding network.h5")
    src.add_argument("--file", metavar="NETWORK", help="a saved network (.h5) or a NIR graph (.nir)")
    p.add_argument("--hw", required=True, metavar="NAME", help="hwspec name (spinn5, kapoho-bay, loihi2) or .toml file")
    p.add_argument("--seed", type=int, default=0, help="seed of random connectors without their own (default 0)")
    p.add_argument(
        "--dt",
        type=float,
        default=None,
        metavar="MS",
        help="time step on the chip (default: the one RUN_DIR/run.json records, else the hwspec's; "
        "sPyNNaker splits cores below 1 ms)",
    )
    p.add_argument(
        "--plot",
        metavar="PNG",
        help="write the per-core utilisation plot here (default with --run: RUN_DIR/utilisation_<hw>.png)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(handler=run)


def load_network_arg(run_dir: str | None, file: str | None) -> Network:
    """The network named by ``--run`` or ``--file`` (one-sentence errors for missing or unsupported files)."""
    import neurovpr as nv

    if run_dir is not None:
        return RunDir(run_dir).load_network()
    assert file is not None
    path = Path(file)
    if not path.is_file():
        raise ValidationError(f"Network file {file!r} does not exist.")
    if path.suffix.lower() == ".nir":
        from neurovpr.interop.nir import load_nir

        return load_nir(path)
    return nv.load(path)


def run(args: argparse.Namespace) -> int:
    """Check the fit; print a table or JSON."""
    from neurovpr.hardware import check_network
    from neurovpr.hardware.hwspec import load_hwspec
    from neurovpr.hardware.plots import plot_utilisation

    spec = load_hwspec(args.hw)
    network = load_network_arg(args.run, args.file)
    dt, source = args.dt, "--dt"
    if dt is None:
        recorded = RunDir(args.run).time_step() if args.run is not None else None
        dt, source = recorded if recorded is not None else (None, f"{spec.name} [timing].time_step_ms")
    report = check_network(network, spec, seed=args.seed, dt=dt)
    plot = args.plot
    if plot is None and args.run is not None:
        plot = str(Path(args.run) / f"utilisation_{spec.name}.png")
    if plot is not None:
        plot_utilisation(report, plot)
    if args.json:
        out = report.as_dict()
        out["dt_source"] = source
        out["plot"] = plot
        print(json.dumps(out, indent=2))
    else:
        print(report.table())
        print(f"time step {report.spec.timing.time_step_ms:g} ms from {source}")
        if plot is not None:
            print(f"utilisation plot: {plot}")
    return 0 if report.fits else 1
