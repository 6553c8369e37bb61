"""Entry point of the ``neurovpr`` program: parses arguments and dispatches subcommands.

Each subcommand lives in its own module of this package with two functions,
``add_parser(subparsers)`` and ``run(args) -> int``. Exit codes: 0 ok, 1 "does not
fit / check failed", 2 bad input (any :class:`~neurovpr.errors.NeurovprError`).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from neurovpr.cli.arguments import validate
from neurovpr.errors import NeurovprError

#: Subcommand modules, in the order ``--help`` lists them.
COMMANDS = ("demo", "backends", "train", "eval", "check", "energy", "compare", "export", "import")

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    """argparse exits 2 on bad arguments already; keep its message to one line (``--help`` shows the usage)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser with every subcommand."""
    from neurovpr import __version__

    parser = _Parser(
        prog="neurovpr",
        description="Spiking networks for visual place recognition, on simulators and emulated neuromorphic chips.",
    )
    parser.add_argument("--version", action="version", version=f"neurovpr {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMANDS:
        module = importlib.import_module(f"neurovpr.cli.{name}_cmd")
        module.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code."""
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args, extra = parser.parse_known_args(argv)
    if extra and not getattr(args, "model_options", False):
        parser.parse_args(argv)  # argparse's own one-line refusal of the unknown arguments
    args.argv = argv
    try:
        validate(args, args.command, argv)
        return int(args.handler(args))
    except NeurovprError as exc:
        print(f"neurovpr {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"neurovpr {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
