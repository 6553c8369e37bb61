"""``neurovpr demo``: the tour's four parts, its HTML report and the consistency of its tables.

The default run tours every part at toy sizes (``TourSize.tiny()``) on a few backends;
the full demo, as ``bash scripts/bootstrap.sh demo`` runs it, is marked slow.
"""

from __future__ import annotations

import base64
import html
import json
import re
from pathlib import Path

import pytest

from neurovpr.apps.tour import TourSize, run_tour
from neurovpr.apps.tour.fit_part import remedy
from neurovpr.apps.tour.report import SECTIONS
from neurovpr.hardware import check_network

_IMG = re.compile(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"')


def _images(page: str) -> list[bytes]:
    return [base64.b64decode(m) for m in _IMG.findall(page)]


def _section(page: str, key: str) -> str:
    start = page.index(f'<section id="{key}">')
    return page[start : page.index("</section>", start)]


def _check_report(summary: dict, out: Path) -> str:
    page = (out / "report.html").read_text(encoding="utf-8")
    assert summary["report"] == str(out / "report.html")
    for key, title in SECTIONS.items():
        assert html.escape(title) in _section(page, key)
    images = _images(page)
    pngs = sorted(out.glob("*.png"))
    assert len(images) == len(pngs) >= 6, "every PNG the tour wrote is embedded in the page"
    assert sorted(images) == sorted(p.read_bytes() for p in pngs)
    assert all(img[:8] == b"\x89PNG\r\n\x1a\n" for img in images)
    saved = json.loads((out / "summary.json").read_text())
    assert saved == {k: v for k, v in summary.items() if k != "report"}
    return page


def _check_backends(part: dict, page: str) -> None:
    rows = part["rows"]
    assert rows[0]["backend"] == part["reference_backend"] == "reference"
    assert rows[0]["identical_counts"] == 1.0 and rows[0]["count_correlation"] == pytest.approx(1.0)
    section = _section(page, "backends")
    for row in rows:
        assert 0.0 <= row["identical_counts"] <= 1.0 and row["seconds_per_simulated_second"] > 0
        assert set(row["spikes"]) == {"hidden", "output"} and row["spikes"]["hidden"] > 0
        cells = [row["backend"], *map(str, row["spikes"].values()), f"{row['identical_counts']:.3f}"]
        assert "".join(f"<td>{c}</td>" for c in cells) in section
    for name, why in part["refused"].items():
        assert html.escape(name) in section and why.endswith(".")


def _check_fit(part: list[dict], page: str) -> None:
    by_label = {c["label"]: c for c in part}
    assert by_label["mbsnn_spinn5"]["fits"] and by_label["locsnet_kapoho-bay"]["fits"]
    failing = by_label["mbsnn_kapoho-bay"]
    assert not failing["fits"] and failing["violations"]
    section = _section(page, "fit")
    for c in part:
        assert f"<td>{c['cores']} / {c['max_cores']}</td><td>{c['chips']} / {c['max_chips']}</td>" in section
        assert c["cores"] == sum(p["cores"] for p in c["populations"])
    for v in failing["violations"]:
        assert v["where"].split("[")[0] in v["remedy"] and html.escape(v["remedy"]) in section


def _check_onchip(part: dict, page: str) -> None:
    ran = part["rows"]
    assert ran[0]["backend"] == "reference" and ran[0]["R@1_drop"] == 0.0
    for row in ran:
        assert row["R@1_drop"] == pytest.approx(ran[0]["R@1"] - row["R@1"])
        assert row["joules_per_inference"] > 0
    assert len(ran) + len(part["refused"]) >= 2
    section = _section(page, "onchip")
    for row in ran:
        assert f"<td>{row['R@1']:.3f}</td><td>{row['R@1_drop']:+.3f}</td>" in section


def _check_modular(part: dict, page: str) -> None:
    assert set(part["R@1"]) >= {"Modular SNN", "SAD"}
    section = _section(page, "modular")
    for name, values in part["R@1"].items():
        assert set(values) == {f"L={n}" for n in part["seq_lens"]}
        assert all(0.0 <= v <= 1.0 for v in values.values())
        cells = "".join(f"<td>{values[f'L={n}']:.3f}</td>" for n in part["seq_lens"])
        assert f"<td>{html.escape(name)}</td>{cells}" in section
    assert set(part["plots"]) == {"distance_matrix", "pr_curve"}


def test_tiny_tour_writes_a_consistent_report(tmp_path: Path) -> None:
    out = tmp_path / "tour"
    summary = run_tour(out, size=TourSize.tiny(), workers=1, backends=("reference", "nengo", "spinnaker"),
                       onchip_backends=("reference", "lava-fixed"))  # fmt: skip
    page = _check_report(summary, out)
    assert "spinnaker" in summary["backends"]["refused"], "a mapping-only backend is named, not run"
    _check_backends(summary["backends"], page)
    _check_fit(summary["fit"], page)
    _check_onchip(summary["onchip"], page)
    _check_modular(summary["modular"], page)


def test_remedy_names_the_population_and_how_much() -> None:
    import neurovpr as nv

    net = nv.Network("wide")
    net.add_population("src", 10, nv.SpikeSourcePoisson(rate=5.0))
    net.add_population("a", 10, nv.IF_cond_exp())
    net.connect("src", "a", nv.AllToAllConnector(), nv.StaticSynapse(weight=0.1))
    report = check_network(net, "kapoho-bay", dt=1.0)
    v = report.as_dict()["violations"][0]
    assert v["limit"] == "neuron model" and "IF_curr_exp" in remedy(v, report) and "'a'" in remedy(v, report)
    axons = {"limit": "output axons per core", "where": "pn[0:100]", "value": 14479, "maximum": 4096}
    assert "'pn'" in remedy(axons, report) and "about 4 times" in remedy(axons, report)


@pytest.mark.slow
def test_full_demo_from_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from neurovpr.cli.main import main

    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    page = _check_report(summary, out)
    _check_backends(summary["backends"], page)
    _check_fit(summary["fit"], page)
    _check_onchip(summary["onchip"], page)
    _check_modular(summary["modular"], page)
    assert summary["size"]["n_kc"] == 4000 and summary["size"]["n_pn"] == 840, "the MBSNN is checked at its paper size"
