"""``neurovpr export (--run RUN_DIR | --file NETWORK.h5) --format nir --out FILE``: write a network as NIR."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from neurovpr.errors import ValidationError

FORMATS = ("nir",)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "export",
        help="write a network in an interchange format (NIR)",
        description=(
            "Export a saved network (or a run's network.h5) to the Neuromorphic Intermediate Representation, "
            "for snnTorch, Norse, Lava-dl, Rockpool, Sinabs or Spyx. What NIR cannot express (conductance "
            "synapses, adaptive thresholds, plasticity, ...) is refused with one sentence naming it."
        ),
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--run", metavar="RUN_DIR", help="a run directory holding network.h5")
    src.add_argument("--file", metavar="NETWORK.h5", help="a saved network")
    p.add_argument("--format", required=True, choices=FORMATS, help="output format")
    p.add_argument("--out", required=True, type=Path, metavar="FILE", help="the file to write (e.g. net.nir)")
    p.add_argument("--dt", type=float, default=0.1, metavar="MS",
                   help="NIR step h in ms: the charge of one spike and, with --integration euler, the peer's "
                        "time step (default 0.1 ms, snnTorch's 1e-4 s)")  # fmt: skip
    p.add_argument("--integration", choices=("exact", "euler"), default="exact",
                   help="write continuous-time parameters (exact, default) or the forward-Euler coefficients "
                        "a peer uses at step --dt (euler: as snnTorch simulates)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0, help="seed of random connectors and weights without their own (default 0)")
    p.add_argument("--allow-refractory", action="store_true",
                   help="keep refractory periods in neurovpr metadata only (peers run without them) instead of refusing")
    p.add_argument("--outputs", metavar="POP[,POP...]",
                   help="populations to mark as NIR Output (default: those with no outgoing projection)")  # fmt: skip
    p.add_argument("--no-embed", action="store_true", help="do not carry the neurovpr network in the file's metadata")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Export and report what peers will not see."""
    from neurovpr.interop.nir import export_nir, read_graph

    from .check_cmd import load_network_arg

    if args.file is not None and Path(args.file).suffix.lower() == ".nir":
        raise ValidationError(f"--file {args.file!r} is a NIR graph already; export reads a saved network (.h5).")
    network = load_network_arg(args.run, args.file)
    outputs = [o for o in args.outputs.split(",") if o] if args.outputs else None
    notes = export_nir(
        network, args.out, dt=args.dt, integration=args.integration, seed=args.seed,
        allow_refractory=args.allow_refractory, outputs=outputs, embed_network=not args.no_embed,
    )  # fmt: skip
    graph = read_graph(args.out)
    summary = {
        "out": str(args.out),
        "format": args.format,
        "network": network.name,
        "nodes": {name: type(node).__name__ for name, node in graph.nodes.items()},
        "edges": [list(e) for e in graph.edges],
        "dt_ms": args.dt,
        "integration": args.integration,
        "notes": list(notes),
    }
    if args.json:
        print(json.dumps(summary))
        return 0
    print(f"wrote {args.out}: network {network.name!r} as {len(graph.nodes)} NIR nodes, {len(graph.edges)} edges "
          f"({args.integration}, dt {args.dt:g} ms)")  # fmt: skip
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    return 0
