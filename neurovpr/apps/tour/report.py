"""The tour's report: one self-contained HTML page, tables and every PNG embedded (base64).

Also draws the backends part's plot. The page is written atomically; its sections carry
``id`` attributes (``backends``, ``fit``, ``onchip``, ``modular``) so tests and links
can find them.
"""

from __future__ import annotations

import base64
import html
from pathlib import Path
from typing import Any

import numpy as np

from neurovpr.fileio import atomic_write_text, save_figure

__all__ = ["SECTIONS", "plot_backends", "write_html"]

#: Section ids and titles, in page order.
SECTIONS = {
    "backends": "1. One network, declared once, on every backend",
    "fit": "2. Does it fit the chip?",
    "onchip": "3. Off-chip vs on-chip: a small trained LoCS-Net",
    "modular": "4. The Modular SNN next to SAD",
}


def _fmt(value: Any, spec: str = ".3f") -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return format(value, spec)
    return html.escape(str(value))


def _table(head: list[str], rows: list[list[str]]) -> str:
    th = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def _image(folder: Path, name: str | None, alt: str) -> str:
    if not name:
        return ""
    data = base64.b64encode((folder / name).read_bytes()).decode("ascii")
    img = f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'
    return f"<figure>{img}<figcaption>{html.escape(name)}</figcaption></figure>"


def _refusals(refused: dict[str, str]) -> str:
    if not refused:
        return ""
    items = "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>" for k, v in refused.items())
    return f"<p>Not run here:</p><ul>{items}</ul>"


def plot_backends(part: dict[str, Any], path: Path) -> Path:
    """Bars per backend: wall seconds per simulated second (log) and the spike-count correlation with the reference."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = part["rows"]
    names = [r["backend"] for r in rows]
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.6))
    left.bar(names, [r["seconds_per_simulated_second"] for r in rows], color="tab:blue")
    left.set_yscale("log")
    left.set_ylabel("wall s per simulated s")
    left.set_title("cost")
    x = np.arange(len(rows))
    right.bar(x - 0.2, [r["count_correlation"] or 0.0 for r in rows], width=0.4, color="tab:green", label="r of counts")
    right.bar(x + 0.2, [r["identical_counts"] for r in rows], width=0.4, color="tab:olive", label="identical counts")
    right.set_xticks(x, names)
    right.set_ylim(0, 1.0)
    right.legend(fontsize="small", ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.3))
    right.set_title("agreement with " + str(part["reference_backend"]))
    for ax in (left, right):
        ax.tick_params(axis="x", rotation=30)
        ax.grid(axis="y", alpha=0.3)
    fig.suptitle(f"{part['network']}, {part['duration_ms']:g} ms at dt {part['dt_ms']:g} ms")
    fig.tight_layout()
    try:
        return save_figure(fig, path, dpi=100, bbox_inches="tight")
    finally:
        plt.close(fig)


def _backends_html(part: dict[str, Any], folder: Path) -> str:
    rows = [
        [html.escape(r["backend"]), *(str(v) for v in r["spikes"].values()), _fmt(r["identical_counts"]),
         _fmt(r["count_correlation"]), _fmt(r["compile_seconds"], ".2f"), _fmt(r["warm_up_seconds"], ".2f"),
         _fmt(r["seconds_per_simulated_second"], ".4g")]
        for r in part["rows"]
    ]  # fmt: skip
    pops = list(part["rows"][0]["spikes"]) if part["rows"] else []
    head = ["backend", *(f"spikes {p}" for p in pops), "identical counts", "r(counts)", "compile s", "first run s",
            "s per sim. s"]
    intro = (
        f"<p>{html.escape(part['network'])}, declared once with <code>nv.Network</code> and run with "
        f"<code>nv.compile(net, backend=NAME)</code> for {part['duration_ms']:g} ms at dt {part['dt_ms']:g} ms. "
        f"Agreement is against <code>{html.escape(str(part['reference_backend']))}</code>: the share of neurons with "
        "the same spike count and Pearson's r of the per-neuron counts. Fixed-point chips and Nengo's LIF "
        "discretisation differ from exact integration by design; the conformance suite states each backend's "
        "tolerance. Cost: an untimed first run of a tenth of the time (one-time costs such as numba's JIT on a fresh "
        "install), a reset, then the timed run.</p>"
    )
    return intro + _table(head, rows) + _refusals(part["refused"]) + _image(folder, part.get("plot"), "backends")


def _fit_html(part: list[dict[str, Any]], folder: Path) -> str:
    rows = [
        [html.escape(c["network"]), html.escape(c["title"]), _fmt(c["dt_ms"], "g"),
         "<b>fits</b>" if c["fits"] else "<b>does not fit</b>", f"{c['cores']} / {c['max_cores']}",
         f"{c['chips']} / {c['max_chips']}", str(len(c["violations"]))]
        for c in part
    ]  # fmt: skip
    out = _table(["network", "hardware", "dt ms", "verdict", "cores used / board", "chips used / board", "limits broken"], rows)
    for c in part:
        out += f"<h3>{html.escape(c['network'])} on {html.escape(c['title'])}</h3>"
        if c["violations"]:
            vrows = [[html.escape(v["limit"]), html.escape(v["where"]), _fmt(v["value"], "g"), _fmt(v["maximum"], "g"),
                      html.escape(v["remedy"])] for v in c["violations"]]  # fmt: skip
            out += _table(["limit", "where", "value", "maximum", "what would make it fit"], vrows)
        out += _image(folder, c["plot"], f"utilisation {c['label']}")
    return out


def _onchip_html(part: dict[str, Any], folder: Path) -> str:
    rows = [
        [html.escape(r["backend"]), html.escape(r["where"]), _fmt(r["R@1"]), _fmt(r["R@1_drop"], "+.3f"),
         _fmt(r["agreement"]), _fmt(r["seconds_per_query"], ".3g"), _fmt(r["joules_per_inference"], ".3g"),
         _fmt(r["dynamic_joules_per_inference"], ".3g")]
        for r in part["rows"]
    ]  # fmt: skip
    head = ["backend", "runs as", "R@1", "drop vs off-chip", "agreement", "s/query",
            f"J/inference ({part['hardware']})", "of which activity (J)"]  # fmt: skip
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in part["notes"])
    intro = f"<p>{html.escape(part['about'])}</p>"
    return intro + _table(head, rows) + (f"<ul>{notes}</ul>" if notes else "") + _refusals(part["refused"]) + _image(
        folder, part["plot"], "off-chip vs on-chip"
    )


def _modular_html(part: dict[str, Any], folder: Path) -> str:
    cols = [f"L={n}" for n in part["seq_lens"]]
    rows = [[html.escape(name), *(_fmt(values.get(c)) for c in cols)] for name, values in part["R@1"].items()]
    intro = (
        f"<p>{html.escape(str(part['plan']))}; {part['members']} member(s), {part['epochs']} epochs, defaults following "
        "the authors' code. R@1 with sequence matching of length L; SAD on the same images.</p>"
    )
    figs = "".join(_image(folder, name, key) for key, name in part["plots"].items())
    return intro + _table(["method", *(f"R@1 {c}" for c in cols)], rows) + figs


_CSS = (
    "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.8em 0}td,th{border:1px solid #bbb;padding:0.25em 0.6em;text-align:right}"
    "td:first-child,th:first-child{text-align:left}th{background:#eee}img{max-width:100%}"
    "figure{margin:0.8em 0}figcaption{font-size:small;color:#666}"
)


def write_html(summary: dict[str, Any], folder: Path) -> Path:
    """Write ``folder/report.html`` from the tour's summary (PNGs read from ``folder``); returns its path."""
    parts = {
        "backends": _backends_html(summary["backends"], folder),
        "fit": _fit_html(summary["fit"], folder),
        "onchip": _onchip_html(summary["onchip"], folder),
        "modular": _modular_html(summary["modular"], folder),
    }
    body = "".join(f'<section id="{key}"><h2>{html.escape(SECTIONS[key])}</h2>{parts[key]}</section>' for key in SECTIONS)
    head = (
        f"<h1>neurovpr tour</h1><p>Data: {html.escape(summary['data'])}. Took {summary['total_seconds']:.0f} s on "
        f"{html.escape(summary['machine'])}.</p>"
    )
    meta = f'<meta charset="utf-8"><title>neurovpr tour</title><style>{_CSS}</style>'
    page = f'<!DOCTYPE html><html lang="en"><head>{meta}</head><body>{head}{body}</body></html>\n'
    path = folder / "report.html"
    atomic_write_text(path, page)
    return path
