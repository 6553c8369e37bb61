"""Every model option is declared once, in its options dataclass, and the command line is generated from it.

``neurovpr.apps.options.add_option_arguments`` makes one flag per field (type, choices,
default and help from the field); ``neurovpr.cli.arguments.model_options`` builds the
options back by destination name. These tests fail when a flag and a field drift apart,
when a field cannot be given on the command line, or when a default is stated twice.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path

import pytest

from neurovpr import models
from neurovpr.apps.options import add_option_arguments, flag_of, option, options_from_namespace


def _parser(plugin, kind: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(add_help=False, exit_on_error=False)
    getattr(plugin, f"add_{kind}_arguments")(parser)
    return parser


@pytest.mark.parametrize("name", models.names())
@pytest.mark.parametrize("kind", ["train", "eval"])
def test_every_flag_is_a_field_and_every_field_a_flag(name: str, kind: str) -> None:
    plugin = models.get(name)
    options = getattr(plugin, f"{kind}_options")
    dests = {a.dest for a in _parser(plugin, kind)._actions}
    fields = {f.name for f in dataclasses.fields(options)}
    assert dests == fields, f"{name} {kind}: {sorted(dests ^ fields)}"
    # nothing given: exactly the dataclass's defaults (no default lives in the parser)
    assert options_from_namespace(_parser(plugin, kind).parse_args([]), options) == options()


@pytest.mark.parametrize("name", models.names())
def test_help_states_each_default_of_the_dataclass(name: str) -> None:
    plugin = models.get(name)
    text = " ".join(_parser(plugin, "train").format_help().split())
    for field in dataclasses.fields(plugin.train_options):
        assert flag_of(field) in text
        if field.default not in (None, False, ()) and "default_text" not in field.metadata:
            shown = format(field.default, "g") if isinstance(field.default, float) else str(field.default)
            assert f"(default: {shown})" in text, f"{name}: {field.name}"


def test_locsnet_training_defaults_come_from_its_training_settings() -> None:
    """LoCS-Net's training hyper-parameters have one default each, in TrainingSettings."""
    from neurovpr.models.locsnet.settings import TrainingSettings

    options = models.get("locsnet").train_options()
    settings = TrainingSettings()
    for name in ("epochs", "batch_size", "learning_rate", "weight_decay", "rate_penalty", "quantise", "place_loss", "threads"):
        assert getattr(options, name) == getattr(settings, name), name


@dataclass(frozen=True, slots=True, kw_only=True)
class _Sample:
    count: int = option(3, "how many")
    rate: float | None = option(None, "a rate", default_text="none given")
    mode: str = option("a", "the mode")
    paths: tuple[Path, ...] = option((), "extra paths")
    loud: bool = option(False, "say more")
    hw: str | None = option(None, "hardware", flag="--hw")


def test_generated_parser_types_and_flags() -> None:
    parser = argparse.ArgumentParser(exit_on_error=False)
    add_option_arguments(parser, _Sample)
    args = parser.parse_args(["--count", "5", "--rate", "2.5", "--paths", "x", "--paths", "y", "--loud", "--hw", "loihi2"])
    got = options_from_namespace(args, _Sample)
    assert got == _Sample(count=5, rate=2.5, paths=[Path("x"), Path("y")], loud=True, hw="loihi2")  # type: ignore[arg-type]
    assert options_from_namespace(parser.parse_args([]), _Sample) == _Sample()
    with pytest.raises(argparse.ArgumentError):
        parser.parse_args(["--count", "many"])
    assert "(default: none given)" in parser.format_help() and "(default: 3)" in parser.format_help()


def test_a_field_without_help_or_default_is_refused() -> None:
    @dataclass(frozen=True)
    class NoHelp:
        count: int = 3

    @dataclass(frozen=True)
    class Switch:
        on: bool = option(True, "a switch that is on")

    for kind, match in ((NoHelp, "has no help"), (Switch, "defaults to False")):
        with pytest.raises(TypeError, match=match):
            add_option_arguments(argparse.ArgumentParser(), kind)
