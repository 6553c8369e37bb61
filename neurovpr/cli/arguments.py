"""The one argument-validation layer of the command line: every value and output path, before any work.

:func:`validate` runs right after parsing (and again on the chosen model's own
options for ``train``/``eval``). It checks every option it knows by its destination
name, wherever a command or a model declares it, so a rule is written once:

- numbers (:data:`NUMBERS`): seeds, worker counts, sequence lengths, windows, sizes,
  durations, time steps and rates must be finite and within their range;
- output paths (:data:`OUTPUTS`): checked with :func:`neurovpr.fileio.check_output`
  (right kind of entry, a folder this process can write, a ``.png`` where a plot
  is written, never one of the command's own inputs);
- options given where they do not apply (:data:`ONLY_WITH`).

A refusal is a :class:`~neurovpr.errors.ValidationError` naming the option and the
value; the program prints it as one line and exits 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

from neurovpr.apps.options import options_from_namespace
from neurovpr.apps.requests import NUMBERS, Number
from neurovpr.apps.rundir import RunDir
from neurovpr.errors import NeurovprError, ValidationError
from neurovpr.fileio import check_output

__all__ = [
    "ModelHelp",
    "Number",
    "NUMBERS",
    "OUTPUTS",
    "ONLY_WITH",
    "validate",
    "option_given",
    "parse_model_options",
    "model_options",
    "show_progress",
]

Kind = Literal["file", "folder"]
#: Output options: ``(command, destination) -> (kind, required suffix)``.
OUTPUTS: dict[tuple[str, str], tuple[Kind, str | None]] = {
    ("train", "out"): ("folder", None),
    ("demo", "out"): ("folder", None),
    ("eval", "report"): ("folder", None),
    ("eval", "activity_plots"): ("folder", None),
    ("check", "plot"): ("file", ".png"),
    ("compare", "plot"): ("file", ".png"),
    ("export", "out"): ("file", None),
    ("import", "out"): ("file", None),
}
#: Input options whose files an output must never be (``network.h5`` of a ``--run`` counts).
_INPUTS = ("file", "graph", "data", "checkpoint", "positions", "eval_positions")
#: Options that apply only when another is given: ``(command, option) -> (needed destination, its flag)``.
ONLY_WITH: dict[tuple[str, str], tuple[str, str]] = {
    ("energy", "--rate"): ("file", "--file"),
    ("energy", "--duration"): ("file", "--file"),
    ("energy", "--dt"): ("file", "--file"),
}


class ModelHelp(argparse.Action):
    """``--help`` of a command with per-model options: the chosen model's options only.

    ``model_parser(namespace)`` gives the parser of the model chosen by the options
    parsed so far (``--model`` for ``train``, the run's model for ``eval``), or
    ``None``; then the command's common options are shown with ``hint``.
    """

    def __init__(self, option_strings: Sequence[str], dest: str, *, model_parser: Any, hint: str, **_: Any) -> None:
        super().__init__(option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, nargs=0, help="show this help")
        self.model_parser, self.hint = model_parser, hint

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, *_: Any) -> None:
        try:
            chosen = self.model_parser(namespace)
        except NeurovprError as exc:
            parser.exit(2, f"{parser.prog}: error: {exc}\n")
        if chosen is None:
            parser.print_help()
            print(f"\n{self.hint}")
        else:
            chosen.print_help()
        parser.exit(0)


def option_given(argv: Sequence[str], flag: str) -> bool:
    """Whether ``flag`` appears in ``argv`` (as ``--flag VALUE`` or ``--flag=VALUE``)."""
    return any(arg == flag or arg.startswith(f"{flag}=") for arg in argv)


def _flag(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def _inputs(args: argparse.Namespace) -> list[Path]:
    paths = [Path(v) for name in _INPUTS if isinstance(v := getattr(args, name, None), (str, Path))]
    run = getattr(args, "run", None)
    if isinstance(run, (str, Path)):
        paths += [RunDir(run).network_file, RunDir(run).info_file]
    return paths


def validate(args: argparse.Namespace, command: str, argv: Sequence[str] = ()) -> None:
    """Check every known option of ``args`` (see the module docstring); raise one sentence on the first problem."""
    for dest, rule in NUMBERS.items():
        value = getattr(args, dest, None)
        if value is not None and not isinstance(value, (list, tuple)):
            rule.check(_flag(dest), value)
    for (cmd, flag), (needed, needed_flag) in ONLY_WITH.items():
        if cmd == command and option_given(argv, flag) and getattr(args, needed, None) is None:
            raise ValidationError(f"{flag} applies only with {needed_flag}; it is refused here rather than ignored.")
    inputs = _inputs(args)
    for (cmd, dest), (kind, suffix) in OUTPUTS.items():
        value = getattr(args, dest, None)
        if cmd == command and value is not None:
            check_output(value, kind=kind, option=_flag(dest), inputs=inputs, suffix=suffix)


def parse_model_options(parser: argparse.ArgumentParser, argv: Sequence[str], command: str, model: str) -> argparse.Namespace:
    """Parse ``argv`` with a parser that holds the common options and ``model``'s own, then :func:`validate` them.

    An option of another model is refused naming it, rather than ignored.
    """
    args, extra = parser.parse_known_args(list(argv))
    if extra:
        flag = next((a for a in extra if a.startswith("-")), extra[0])
        raise ValidationError(
            f"{flag.split('=')[0]} does not apply to model {model!r} "
            f"(neurovpr {command} {'--model ' + model if command == 'train' else '--run RUN_DIR'} --help lists its options)."
            if flag.startswith("-")
            else f"unexpected argument {flag!r}."
        )
    validate(args, command, argv)
    return args


def model_options(args: argparse.Namespace, kind: type) -> Any:
    """The model's options dataclass ``kind`` from the parsed ``args`` (a field not given keeps its default)."""
    return options_from_namespace(args, kind)


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars unless ``--no-progress``, or ``--json`` with stderr not a terminal."""
    return not getattr(args, "no_progress", False) and (not getattr(args, "json", False) or sys.stderr.isatty())


def backend_options(pairs: Sequence[str] | None) -> dict[str, Any]:
    """The backend options of repeated ``--backend-option KEY=VALUE`` arguments.

    A value reads as ``true``/``false`` (any case), ``none``, an integer, a number, else as the
    string itself (``--backend-option dtype=float32 --backend-option fuse=true``); the backend
    checks the names and values (``neurovpr backends`` lists its options).
    """
    out: dict[str, Any] = {}
    for pair in pairs or ():
        key, sep, text = pair.partition("=")
        if not sep or not key.strip():
            raise ValidationError(f"--backend-option {pair!r} is not KEY=VALUE (e.g. --backend-option fuse=true).")
        out[key.strip()] = _option_value(text.strip())
    return out


def _option_value(text: str) -> Any:
    lowered = text.lower()
    if lowered in ("true", "false"):
        return lowered == "true"
    if lowered == "none":
        return None
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text
