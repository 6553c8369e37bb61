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
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from neurovpr.apps.rundir import NETWORK_FILE, RUN_FILE
from neurovpr.errors import NeurovprError, ValidationError
from neurovpr.fileio import check_output

__all__ = ["ModelHelp", "Number", "NUMBERS", "OUTPUTS", "ONLY_WITH", "validate", "option_given", "parse_model_options"]

_MAX_SEED = 2**63 - 1


@dataclass(frozen=True, slots=True)
class Number:
    """The allowed range of one numeric option (``low``/``high`` inclusive unless ``low_open``)."""

    low: float
    high: float = math.inf
    integer: bool = True
    low_open: bool = False
    unit: str = ""
    shown_high: str = ""

    def check(self, option: str, value: object) -> None:
        """Refuse ``value`` outside the range, naming ``option``."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValidationError(f"{option} must be a number, got {value!r}.")
        unit = f" {self.unit}" if self.unit else ""
        kind = "an integer" if self.integer else "a number"
        low = f"> {self.low:g}" if self.low_open else f">= {self.low:g}"
        high = f" and <= {self.shown_high or format(self.high, 'g')}{unit}" if math.isfinite(self.high) else unit
        ok = math.isfinite(value) and (value > self.low if self.low_open else value >= self.low) and value <= self.high
        if not ok or (self.integer and value != int(value)):
            shown = format(value, "g") if isinstance(value, float) else str(value)
            raise ValidationError(f"{option} is {shown}; it must be {kind} {low}{high}.")


_COUNT = Number(1)
#: Numeric options by destination name, for every command and model that declares them.
NUMBERS: dict[str, Number] = {
    "seed": Number(0, _MAX_SEED, shown_high="2**63 - 1"),
    "workers": Number(1, 1024),
    "threads": Number(1, 1024),
    "seq_len": Number(1, 100_000),
    "windows": Number(1, 1_000_000),
    "members": Number(1, 1000),
    "members_used": Number(1, 1000),
    "epochs": Number(1, 1_000_000),
    "module_size": Number(1, 1_000_000),
    "neurons": Number(1, 100_000),
    "places": _COUNT,
    "max_modules": _COUNT,
    "queries": _COUNT,
    "batch_size": _COUNT,
    "frames_per_place": _COUNT,
    "calibration_images": _COUNT,
    "duration": Number(0, 1e9, integer=False, low_open=True, unit="ms"),
    "presentation": Number(0, 1e9, integer=False, low_open=True, unit="ms"),
    "dt": Number(0, 10, integer=False, low_open=True, unit="ms"),
    "timestep": Number(0, 10, integer=False, low_open=True, unit="ms"),
    "rate": Number(0, 1e6, integer=False, unit="Hz"),
    "input_rate": Number(0, 1e6, integer=False, unit="Hz"),
    "stretch": Number(0, 1e6, integer=False, low_open=True),
    "theta": Number(0, 1e9, integer=False),
    "tau_syn": Number(0, 1e9, integer=False, low_open=True, unit="ms"),
    "tile_size": Number(0, 1e12, integer=False, low_open=True, unit="m"),
    "learning_rate": Number(0, 1e3, integer=False, low_open=True),
    "weight_decay": Number(0, 1e3, integer=False),
    "rate_penalty": Number(0, 1e6, integer=False),
}

Kind = Literal["file", "folder"]
#: Output options: ``(command, destination) -> (kind, required suffix)``.
OUTPUTS: dict[tuple[str, str], tuple[Kind, str | None]] = {
    ("train", "out"): ("folder", None),
    ("demo", "out"): ("folder", None),
    ("eval", "report"): ("folder", None),
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
        paths += [Path(run) / NETWORK_FILE, Path(run) / RUN_FILE]
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
