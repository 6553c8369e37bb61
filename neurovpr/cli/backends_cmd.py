"""``neurovpr backends``: list backends, whether they import here, and what they can run."""

from __future__ import annotations

import argparse
import json

from neurovpr.runtime.registry import backend_infos


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Register the subcommand."""
    p = sub.add_parser("backends", help="list the backends and their capabilities")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Print the table (or JSON)."""
    infos = backend_infos()
    if args.json:
        print(json.dumps({"backends": [i.as_dict() for i in infos]}, indent=2))
        return 0
    rows = [("backend", "available", "version", "learns", "runs", "notes")]
    for info in infos:
        caps = info.backend.capabilities if info.backend is not None else None
        note = info.reason or (caps.run_refusal if caps and not caps.runs else info.description)
        rows.append(
            (
                info.name,
                "yes" if info.available else "no",
                info.version or "-",
                ("yes" if caps.learns else "no") if caps else "-",
                ("yes" if caps.runs else "no") if caps else "-",
                note,
            )
        )
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    for r in rows:
        print("  ".join(c.ljust(w) for c, w in zip(r[:5], widths, strict=True)) + "  " + r[5])
    return 0
