"""``neurovpr train --model X --help`` and ``eval --run DIR --help`` list model X's options only, with their defaults."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from neurovpr.cli.main import main

#: A flag only each model has.
OWN = {"modular": "--module-size", "mbsnn": "--n-kc", "locsnet": "--feature-groups"}


def _help(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("model", sorted(OWN))
def test_train_help_lists_only_the_chosen_models_options(model: str, capsys: pytest.CaptureFixture[str]) -> None:
    text = _help(["train", "--model", model, "--help"], capsys)
    assert OWN[model] in text and "--no-progress" in text
    assert [flag for name, flag in OWN.items() if name != model and flag in text] == []


def test_train_help_shows_the_dataclass_default(capsys: pytest.CaptureFixture[str]) -> None:
    from neurovpr.models.locsnet.settings import TrainingSettings

    text = " ".join(_help(["train", "--model", "locsnet", "--help"], capsys).split())
    assert f"training epochs (default: {TrainingSettings().epochs})" in text


def test_eval_help_lists_the_runs_model_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "run.json").write_text(json.dumps({"model": "mbsnn"}))
    text = _help(["eval", "--run", str(tmp_path), "--help"], capsys)
    assert "--windows" in text and "--module-size" not in text
