"""The requests' field checker (neurovpr/apps/requests.py): one rule per kind of type hint, one sentence per refusal."""

from __future__ import annotations

import types
from pathlib import Path

import pytest

from neurovpr.apps.requests import EvalRequest, TrainRequest
from neurovpr.errors import ValidationError


def test_fields_are_normalised() -> None:
    r = EvalRequest(run="runs/a", data=None, seq_len=4, backend_options={"fuse": True, "batch_size": 64, "device": None})
    assert r.run == Path("runs/a") and r.seq_len == 4
    assert isinstance(r.backend_options, types.MappingProxyType)  # frozen like the request
    assert dict(r.backend_options) == {"fuse": True, "batch_size": 64, "device": None}
    assert dict(EvalRequest(run="a").backend_options) == {}


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"backend_options": "fuse=true"}, "EvalRequest.backend_options must be a mapping, got 'fuse=true'."),
        ({"backend_options": {3: True}}, "EvalRequest.backend_options key must be a string, got 3."),
        ({"backend_options": {"fuse": [1]}},
         "EvalRequest.backend_options['fuse'] is [1]; it must be a bool, int, float, str or None."),
        ({"seq_len": 2.5}, "EvalRequest.seq_len must be an integer, got 2.5."),
        ({"progress": "yes"}, "EvalRequest.progress must be True or False, got 'yes'."),
        ({"run": 3}, "EvalRequest.run must be a path, got 3."),
    ],
)  # fmt: skip
def test_bad_fields_are_refused_in_one_sentence(kwargs: dict, needle: str) -> None:
    with pytest.raises(ValidationError) as err:
        EvalRequest(**{"run": "a", **kwargs})
    assert str(err.value) == needle


def test_train_request_checks_the_same_way() -> None:
    with pytest.raises(ValidationError, match=r"^TrainRequest.resume must be True or False, got 1.$"):
        TrainRequest(data="d", out="o", resume=1)
