"""EventStream: validation on construction, one-sentence errors, derived views."""

from __future__ import annotations

import numpy as np
import pytest

from neurovpr.data.events import EventStream
from neurovpr.errors import ValidationError


def _stream(**changes):
    fields = {
        "width": 4,
        "height": 3,
        "x": [0, 3, 1, 2],
        "y": [0, 2, 1, 0],
        "t": [0, 10, 10, 25],
        "p": [1, 0, 1, 1],
    }
    fields.update(changes)
    return EventStream(**fields)


def test_valid_stream_is_frozen_and_typed():
    s = _stream()
    assert len(s) == 4 and s.sensor_size == (4, 3)
    assert s.t.dtype == np.int64 and s.x.dtype == np.int32 and s.p.dtype == np.int8
    assert s.duration_us == 25 and s.t_start == 0
    with pytest.raises(ValueError):
        s.t[0] = 5  # read-only copy
    with pytest.raises(AttributeError):
        s.width = 8  # type: ignore[misc]
    assert s == _stream() and s != _stream(p=[1, 1, 1, 1])


def test_polarity_minus_one_plus_one_and_bool_are_normalised():
    assert _stream(p=[1, -1, 1, -1]).p.tolist() == [1, 0, 1, 0]
    assert _stream(p=np.array([True, False, True, True])).p.tolist() == [1, 0, 1, 1]


def test_empty_stream_is_refused_in_one_sentence():
    with pytest.raises(ValidationError) as err:
        _stream(x=[], y=[], t=[], p=[])
    message = str(err.value)
    assert "no events" in message and message.count(".") == 1 and "\n" not in message


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"x": [0, 4, 1, 2]}, "record 1 (0-based) has x=4 outside 0..3"),
        ({"y": [0, 2, -1, 0]}, "record 2 (0-based) has y=-1 outside 0..2"),
        ({"t": [0, 10, 5, 25]}, "record 2 (0-based) has t=5 us before the previous record's t=10 us"),
        ({"t": [-3, 10, 10, 25]}, "record 0 (0-based) has t=-3 us"),
        ({"p": [1, 0, 2, 1]}, "record 2 (0-based) has p=2"),
        ({"x": [0.0, 3.5, 1.0, 2.0]}, "record 1 (0-based) has x=3.5, y=2, but pixel coordinates must be integers"),
    ],
)
def test_first_bad_record_is_named(changes, expected):
    with pytest.raises(ValidationError, match="EventStream: ") as err:
        _stream(**changes)
    assert expected in str(err.value)


def test_first_problem_in_record_order_wins():
    # record 1 is unsorted, record 3 is out of range: record 1 is reported
    with pytest.raises(ValidationError, match=r"record 1 \(0-based\)"):
        _stream(t=[5, 0, 10, 20], x=[0, 1, 2, 9])


def test_time_window_selects_and_refuses_empty():
    s = _stream()
    w = s.time_window(10, 20)
    assert w.t.tolist() == [10, 10] and w.x.tolist() == [3, 1]
    with pytest.raises(ValidationError, match=r"no events in \[26, 30\) us"):
        s.time_window(26, 30)


def test_sensor_size_must_be_positive_integer():
    with pytest.raises(ValidationError, match=r"EventStream\.width"):
        _stream(width=0)
