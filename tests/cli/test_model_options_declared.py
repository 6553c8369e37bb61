"""Every option a model adds to the command line reaches its typed options.

The CLI builds a model's ``train_options`` / ``eval_options`` from the parsed arguments by
destination name (``neurovpr.cli.arguments.model_options``); a flag whose destination is not
a field of the options dataclass would be parsed and then silently dropped.
"""

from __future__ import annotations

import argparse
import dataclasses

import pytest

from neurovpr import models

#: Flags a model may add that the CLI itself turns into request fields, not model options.
REQUEST_LEVEL = {"no_progress"}  # cli.arguments.show_progress -> TrainRequest/EvalRequest.progress


def _dests(add_arguments) -> set[str]:
    parser = argparse.ArgumentParser(add_help=False)
    add_arguments(parser)
    return {a.dest for a in parser._actions}


@pytest.mark.parametrize("name", models.names())
@pytest.mark.parametrize("kind", ["train", "eval"])
def test_every_model_flag_is_a_field_of_its_options(name: str, kind: str) -> None:
    plugin = models.get(name)
    dests = _dests(getattr(plugin, f"add_{kind}_arguments")) - REQUEST_LEVEL
    fields = {f.name for f in dataclasses.fields(getattr(plugin, f"{kind}_options"))}
    assert dests <= fields, f"{name} {kind}: flags without an options field: {sorted(dests - fields)}"
