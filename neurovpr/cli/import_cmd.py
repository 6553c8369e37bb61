"""``neurovpr import GRAPH.nir --out NETWORK.h5``: turn a NIR graph into a saved neurovpr network."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser(
        "import",
        help="read a NIR graph into a saved network",
        description=(
            "Import a Neuromorphic Intermediate Representation graph (from snnTorch, Norse, Lava-dl, Rockpool, ...) "
            "and save it as a neurovpr network file. NIR node types with no neurovpr equivalent are named in an error."
        ),
    )
    p.add_argument("graph", type=Path, metavar="GRAPH.nir", help="the NIR file")
    p.add_argument("--out", required=True, type=Path, metavar="NETWORK.h5", help="the network file to write")
    p.add_argument("--dt", type=float, default=None, metavar="MS",
                   help="NIR step h in ms (default: as exported by neurovpr, else 0.1 ms, snnTorch's 1e-4 s)")
    p.add_argument("--integration", choices=("exact", "euler"), default=None,
                   help="read the parameters as continuous-time (exact) or as forward-Euler coefficients at step "
                        "--dt (euler: reproduces snnTorch's own simulation); default exact")  # fmt: skip
    p.add_argument("--name", default=None, help="name of the network (default: the graph's, else 'nir')")
    p.add_argument("--no-metadata", action="store_true",
                   help="ignore a network embedded by neurovpr's export and map the NIR nodes only")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Import, save and summarise."""
    import neurovpr as nv
    from neurovpr.interop.nir import import_nir

    result = import_nir(args.graph, dt=args.dt, integration=args.integration, name=args.name,
                        use_metadata=not args.no_metadata)  # fmt: skip
    net = result.network
    nv.save(net, args.out)
    summary = {
        "out": str(args.out),
        "network": net.name,
        "populations": {name: {"size": p.size, "cell_type": type(p.cell_type).__name__} for name, p in net.populations.items()},
        "projections": {name: {"pre": p.pre, "post": p.post, "connector": type(p.connector).__name__}
                        for name, p in net.projections.items()},
        "inputs": dict(result.inputs),
        "outputs": dict(result.outputs),
        "restored": result.restored,
        "notes": list(result.notes),
    }
    if args.json:
        print(json.dumps(summary))
        return 0
    print(f"wrote {args.out}: network {net.name!r}, {len(net.populations)} populations, {len(net.projections)} projections"
          + (" (restored exactly from neurovpr metadata)" if result.restored else ""))  # fmt: skip
    for name, p in net.populations.items():
        print(f"  {name:<24} {p.size:>8}  {type(p.cell_type).__name__}")
    for node, pop in result.inputs.items():
        print(f"  input  {node!r} -> population {pop!r}")
    for node, pop in result.outputs.items():
        print(f"  output {node!r} <- population {pop!r}")
    for note in result.notes:
        print(f"note: {note}", file=sys.stderr)
    return 0
