"""A model's command-line options, generated from the fields of its options dataclass.

A model declares its options once, as a frozen dataclass (its ``train_options`` or
``eval_options``); each field's default lives there and nowhere else. :func:`option`
attaches the help text (and, where the flag differs from the field name, the flag)
to a field; :func:`add_option_arguments` turns the fields into ``argparse`` options:

- the flag is ``--`` and the field name with dashes (``batch_size`` -> ``--batch-size``),
  unless the field's metadata names another;
- the type comes from the type hint: ``int``, ``float``, ``str``, ``Path``; ``X | None``
  takes an ``X``; ``Literal[...]`` gives the choices; ``tuple[X, ...]`` a repeatable
  option; ``bool`` (default ``False``) a switch;
- the help is the metadata's ``help``, followed by the field's default;
- an option not given is absent from the parsed namespace, so the dataclass's own
  default applies (:func:`options_from_namespace`).
"""

from __future__ import annotations

import argparse
import dataclasses
import types
import typing
from pathlib import Path
from typing import Any, Literal

__all__ = ["option", "add_option_arguments", "options_from_namespace", "flag_of"]

_SIMPLE = (int, float, str, Path)


def option(
    default: Any, help: str, *, flag: str | None = None, metavar: str | None = None, default_text: str | None = None
) -> Any:
    """A dataclass field with its ``default`` and command-line ``help``.

    Parameters
    ----------
    default
        The field's default (the only place it is written).
    help
        What the option does, in a few words; the default is appended.
    flag
        The command-line flag when it is not ``--field-name`` (``"--hw"``).
    metavar
        The name of the value in ``--help``.
    default_text
        How the default reads in ``--help`` when its value says little (``None`` meaning "all").
    """
    meta = {"help": help, "flag": flag, "metavar": metavar, "default_text": default_text}
    if isinstance(default, (list, dict, set)):
        raise TypeError("an option's default must be immutable (a tuple, not a list).")
    return dataclasses.field(default=default, metadata={k: v for k, v in meta.items() if v is not None})


def flag_of(field: dataclasses.Field[Any]) -> str:
    """The command-line flag of an options field."""
    return field.metadata.get("flag") or "--" + field.name.replace("_", "-")


def _shown(value: Any) -> str:
    if isinstance(value, tuple):
        return "none" if not value else ", ".join(map(str, value))
    return "none" if value is None else format(value, "g") if isinstance(value, float) else str(value)


def _argument(field: dataclasses.Field[Any], hint: Any, owner: str) -> dict[str, Any]:
    """``add_argument`` keywords for one field (type, choices, action)."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        if len(inner) != 1:
            raise TypeError(f"{owner}.{field.name}: a command-line option takes one type, not {hint!r}.")
        hint, origin, args = inner[0], typing.get_origin(inner[0]), typing.get_args(inner[0])
    if origin is Literal:
        return {"choices": args, "type": type(args[0])}
    if origin is tuple:
        if len(args) != 2 or args[1] is not Ellipsis or args[0] not in _SIMPLE:
            raise TypeError(f"{owner}.{field.name}: only tuple[X, ...] of int, float, str or Path is a command-line option.")
        return {"action": "append", "type": args[0]}
    if hint is bool:
        if field.default is not False:
            raise TypeError(f"{owner}.{field.name}: a switch defaults to False (name it for what giving it does).")
        return {"action": "store_true"}
    if hint in _SIMPLE:
        return {"type": hint}
    raise TypeError(f"{owner}.{field.name}: type {hint!r} cannot be a command-line option.")


def add_option_arguments(parser: argparse._ActionsContainer, options: type) -> None:
    """Add one option per field of the dataclass ``options`` to ``parser`` (see the module docstring).

    Raises
    ------
    TypeError
        When a field has no default, no help, or a type the command line cannot give.
    """
    hints = typing.get_type_hints(options)
    for field in dataclasses.fields(options):
        if field.default is dataclasses.MISSING:
            raise TypeError(f"{options.__name__}.{field.name} has no default; every model option needs one.")
        if "help" not in field.metadata:
            raise TypeError(f"{options.__name__}.{field.name} has no help; declare it with neurovpr.apps.options.option().")
        keywords = _argument(field, hints[field.name], options.__name__)
        if "metavar" in field.metadata:
            keywords["metavar"] = field.metadata["metavar"]
        if keywords.get("action") != "store_true":
            text = field.metadata.get("default_text") or _shown(field.default)
            keywords["help"] = f"{field.metadata['help']} (default: {text})".replace("%", "%%")
        else:
            keywords["help"] = field.metadata["help"].replace("%", "%%")
        parser.add_argument(flag_of(field), dest=field.name, default=argparse.SUPPRESS, **keywords)


def options_from_namespace(args: argparse.Namespace, options: type) -> Any:
    """The dataclass ``options`` from parsed ``args``: the fields given, the rest at their defaults."""
    return options(**{f.name: getattr(args, f.name) for f in dataclasses.fields(options) if hasattr(args, f.name)})
