"""``neurovpr energy``: joules per inference of a run on a hardware target."""

from __future__ import annotations

import argparse
import json

from neurovpr.errors import ValidationError


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "energy",
        help="estimate joules per inference of a run on a hardware target",
        description=(
            "Turn the activity counted in a run (RUN_DIR/activity.json) into joules per inference with the "
            "hwspec's energy per operation; uses RUN_DIR/network.h5, when present, for the chips and cores used."
        ),
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--run", metavar="RUN_DIR", help="a run directory holding activity.json")
    src.add_argument("--file", metavar="NETWORK", help="a saved network (.h5) or a NIR graph (.nir), run here with "
                     "Poisson input at --rate for --duration to count its activity")  # fmt: skip
    p.add_argument("--rate", type=float, default=20.0, help="with --file: input firing rate in Hz (default 20)")
    p.add_argument("--duration", type=float, default=100.0, help="with --file: ms per inference (default 100)")
    p.add_argument("--plots", metavar="DIR", default=None,
                   help="with --file: also write the run's spike raster, rate histograms (PNG) and summary to DIR")  # fmt: skip
    p.add_argument("--dt", type=float, default=None, help="with --file: time step in ms (default: the hardware's)")
    p.add_argument("--hw", required=True, metavar="NAME", help="hwspec name (spinn5, kapoho-bay, loihi2) or .toml file")
    p.add_argument("--seed", type=int, default=0, help="seed of random connectors without their own (default 0)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Estimate and print the energy."""
    from neurovpr.apps.rundir import RunDir
    from neurovpr.hardware.energy import ACTIVITY_FILE, estimate_energy, read_activity
    from neurovpr.hardware.hwspec import load_hwspec

    from .check_cmd import load_network_arg

    spec = load_hwspec(args.hw)
    if args.plots is not None and args.file is None:
        raise ValidationError("--plots draws the run that --file makes; a --run directory's run is not kept.")
    if args.file is not None:
        from neurovpr.interop.activity import probe_activity

        network = load_network_arg(None, args.file)
        dt = args.dt if args.dt is not None else spec.timing.time_step_ms
        activity = probe_activity(network, rate_hz=args.rate, duration_ms=args.duration, dt=dt, seed=args.seed,
                                  plots=args.plots)  # fmt: skip
        report = estimate_energy(activity, spec, network=network, seed=args.seed, dt=dt)
        _print(report, activity, args.json)
        return 0
    run = RunDir(args.run).require()
    if not run.part(ACTIVITY_FILE).is_file():
        raise ValidationError(f"Run directory {args.run!r} has no {ACTIVITY_FILE}.")
    activity = read_activity(run.part(ACTIVITY_FILE))
    network = run.load_network() if run.has_network else None
    recorded = run.time_step()  # the step `neurovpr check --run` partitions at
    report = estimate_energy(activity, spec, network=network, seed=args.seed, dt=None if recorded is None else recorded[0])
    _print(report, activity, args.json)
    return 0


def _print(report, activity, as_json: bool) -> None:
    """The report, with the synaptic-operation counts (NeuroBench's) its energy multiplies."""
    from neurovpr.evaluation.neurobench import synaptic_op_summary

    ops = {"Effective_ACs": float(activity["synaptic_events"]), "Effective_MACs": 0.0,
           "plastic_updates": float(activity.get("plastic_updates", 0.0))}  # fmt: skip
    if as_json:
        print(json.dumps({**report.as_dict(), "synaptic_operations": ops}, indent=2))
    else:
        print(report.table())
        print(f"  {synaptic_op_summary(activity)}")
