"""Event files: the real AEDAT 4.0 sample, AEDAT 2.0, array round trips, bad files."""

from __future__ import annotations

import struct

import h5py
import numpy as np
import pytest

from neurovpr.data.events import EventStream, available_aedat4_readers, read_events, write_events
from neurovpr.errors import FileFormatError, NeurovprError, ValidationError

SAMPLE_EVENTS = 111_954  # events in the tonic project's DVXplorer AEDAT 4.0 fixture


def _random_stream(n=500, width=346, height=260, seed=3):
    rng = np.random.default_rng(seed)
    return EventStream(
        width=width,
        height=height,
        x=rng.integers(0, width, n),
        y=rng.integers(0, height, n),
        t=np.sort(rng.integers(1_600_000_000_000_000, 1_600_000_000_500_000, n)),
        p=rng.integers(0, 2, n),
    )


@pytest.mark.parametrize("reader", ["aedat", "dv-processing"])
def test_real_aedat4_sample(shared_data, reader):
    if reader not in available_aedat4_readers():
        pytest.skip(f"the optional AEDAT 4.0 decoder {reader!r} is not installed")
    stream = read_events(shared_data / "aedat4_sample" / "sample.aedat4", reader=reader)
    assert stream.sensor_size == (320, 240)
    assert len(stream) == SAMPLE_EVENTS
    assert np.all(np.diff(stream.t) >= 0)
    assert 0 < stream.duration_us < 1_000_000
    assert set(np.unique(stream.p)) == {0, 1}
    # first events of the file, as the DV software shows them
    assert stream.t[:3].tolist() == [1605537493718345, 1605537493718348, 1605537493718349]
    assert stream.x[:3].tolist() == [154, 149, 148] and stream.y[:3].tolist() == [204, 206, 199]
    assert stream.p[:3].tolist() == [0, 0, 1]


def test_both_aedat4_decoders_agree(shared_data):
    if len(available_aedat4_readers()) < 2:
        pytest.skip("needs both 'aedat' and 'dv-processing' installed")
    path = shared_data / "aedat4_sample" / "sample.aedat4"
    assert read_events(path, reader="aedat") == read_events(path, reader="dv-processing")


@pytest.mark.parametrize("suffix", [".npy", ".npz", ".h5", ".hdf5", ".csv"])
def test_round_trip(tmp_path, suffix):
    stream = _random_stream()
    path = write_events(stream, tmp_path / f"events{suffix}")
    sensor = (346, 260) if suffix == ".npy" else None
    assert read_events(path, sensor_size=sensor) == stream
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left


def test_npy_needs_the_sensor_size(tmp_path):
    path = write_events(_random_stream(), tmp_path / "e.npy")
    with pytest.raises(ValidationError, match=r"does not state its sensor size; pass sensor_size"):
        read_events(path)


def test_sensor_size_conflict_is_refused(tmp_path):
    path = write_events(_random_stream(), tmp_path / "e.npz")
    with pytest.raises(ValidationError, match=r"states sensor size 346x260, but sensor_size=\(640, 480\)"):
        read_events(path, sensor_size=(640, 480))


def test_plain_arrays_aliases_and_time_unit(tmp_path):
    table = np.array([[1, 2, 0.5, -1], [3, 1, 0.75, 1]])  # x, y, t (ms), p in {-1, +1}
    np.save(tmp_path / "plain.npy", table)
    stream = read_events(tmp_path / "plain.npy", sensor_size=(4, 4), time_unit="ms")
    assert stream.t.tolist() == [500, 750] and stream.p.tolist() == [0, 1]
    with h5py.File(tmp_path / "flat.h5", "w") as fh:
        fh["x"], fh["y"], fh["timestamp"], fh["polarity"] = [1, 2], [0, 0], [7, 9], [True, False]
        fh.attrs["width"], fh.attrs["height"] = 3, 1
    flat = read_events(tmp_path / "flat.h5")
    assert flat.sensor_size == (3, 1) and flat.t.tolist() == [7, 9] and flat.p.tolist() == [1, 0]
    (tmp_path / "noheader.csv").write_text("# sensor_size: 5x5\n1,2,3,1\n4,4,5,0\n")
    assert read_events(tmp_path / "noheader.csv").x.tolist() == [1, 4]
    (tmp_path / "reordered.csv").write_text("t,p,x,y\n3,1,1,2\n5,0,4,4\n")
    reordered = read_events(tmp_path / "reordered.csv", sensor_size=(5, 5))
    assert reordered.x.tolist() == [1, 4] and reordered.t.tolist() == [3, 5]


def test_csv_out_of_range_names_file_and_record(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("# sensor_size: 346x260\nx,y,t,p\n10,10,0,1\n11,10,5,1\n400,12,9,0\n5,300,11,1\n")
    with pytest.raises(ValidationError) as err:
        read_events(path)
    message = str(err.value)
    assert str(path) in message and "record 2 (0-based) has x=400 outside 0..345 (sensor width 346)" in message


def test_npz_unsorted_names_file_and_record(tmp_path):
    path = tmp_path / "unsorted.npz"
    np.savez(path, x=[1, 1, 1, 1], y=[0, 0, 0, 0], t=[0, 5, 3, 8], p=[1, 1, 0, 0], width=2, height=2)
    with pytest.raises(ValidationError, match=r"unsorted\.npz.*record 2 \(0-based\) has t=3 us before"):
        read_events(path)


def test_h5_negative_time_names_file_and_record(tmp_path):
    path = tmp_path / "negative.h5"
    with h5py.File(path, "w") as fh:
        group = fh.create_group("events")
        group["x"], group["y"], group["t"], group["p"] = [0, 1], [0, 1], [-5, 3], [1, 0]
        group.attrs["width"], group.attrs["height"] = 2, 2
    with pytest.raises(ValidationError, match=r"negative\.h5.*record 0 \(0-based\) has t=-5 us"):
        read_events(path)


def test_unknown_format_missing_file_missing_column_and_empty(tmp_path):
    odd = tmp_path / "events.bin"
    odd.write_bytes(b"\x00" * 16)
    with pytest.raises(FileFormatError, match=r"events\.bin.*unknown format \(suffix '\.bin'\)"):
        read_events(odd)
    with pytest.raises(ValidationError, match="does not exist"):
        read_events(tmp_path / "absent.csv")
    np.savez(tmp_path / "nop.npz", x=[1], y=[1], t=[1])
    with pytest.raises(FileFormatError, match=r"nop\.npz.*no 'p' column"):
        read_events(tmp_path / "nop.npz", sensor_size=(2, 2))
    (tmp_path / "empty.csv").write_text("x,y,t,p\n")
    with pytest.raises(ValidationError, match=r"empty\.csv.*holds no events"):
        read_events(tmp_path / "empty.csv", sensor_size=(2, 2))
    (tmp_path / "text.csv").write_text("x,y,t,p\n1,2,abc,1\n")
    with pytest.raises(FileFormatError, match=r"text\.csv.*not a numeric CSV"):
        read_events(tmp_path / "text.csv", sensor_size=(4, 4))
    with pytest.raises(FileFormatError, match=r"writing suffix '\.aedat4' is not supported"):
        write_events(_random_stream(), tmp_path / "out.aedat4")


def _aedat2_bytes(records, header=b"#!AER-DAT2.0\r\n# created by a test\r\n#End Of ASCII Header\r\n"):
    body = b"".join(struct.pack(">II", addr, ts) for addr, ts in records)
    return header + body


def _davis_addr(x, y, p):
    return (y << 22) | (x << 12) | (p << 11)


def test_aedat2_davis_layout(tmp_path):
    records = [
        (_davis_addr(10, 20, 1), 100),
        ((1 << 31) | _davis_addr(5, 5, 0), 150),  # APS sample: skipped
        (_davis_addr(345, 259, 0), 200),
        (_davis_addr(1, 2, 1) | (1 << 10), 250),  # external-input event: skipped
        (_davis_addr(0, 0, 1), 2**32 - 10),
        (_davis_addr(3, 4, 0), 5),  # the 32-bit timestamp wrapped
    ]
    path = tmp_path / "davis.aedat"
    path.write_bytes(_aedat2_bytes(records))
    stream = read_events(path, sensor_size=(346, 260))
    assert stream.x.tolist() == [10, 345, 0, 3] and stream.y.tolist() == [20, 259, 0, 4]
    assert stream.p.tolist() == [1, 0, 1, 0]
    assert stream.t.tolist() == [100, 200, 2**32 - 10, 2**32 + 5]
    flipped = read_events(path, sensor_size=(346, 260), flip_y=True)
    assert flipped.y.tolist() == [239, 0, 259, 255]
    with pytest.raises(NeurovprError, match="pass sensor_size"):
        read_events(path)


def test_aedat2_truncated_and_aedat3_refused(tmp_path):
    truncated = tmp_path / "cut.aedat"
    truncated.write_bytes(_aedat2_bytes([(_davis_addr(1, 1, 1), 10)])[:-3])
    with pytest.raises(FileFormatError, match=r"cut\.aedat.*truncated"):
        read_events(truncated, sensor_size=(346, 260))
    v3 = tmp_path / "v3.aedat"
    v3.write_bytes(b"#!AER-DAT3.1\r\n#!END-HEADER\r\n")
    with pytest.raises(FileFormatError, match=r"v3\.aedat.*AEDAT 3\.1, which is not read"):
        read_events(v3)


def test_corrupt_aedat4_is_a_clear_error(tmp_path):
    if not available_aedat4_readers():
        pytest.skip("no AEDAT 4.0 decoder installed")
    path = tmp_path / "broken.aedat4"
    path.write_bytes(b"#!AER-DAT4.0\r\n" + b"\x01\x02garbage" * 4)
    with pytest.raises(FileFormatError, match=r"broken\.aedat4.*could not be decoded"):
        read_events(path)
