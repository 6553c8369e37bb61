"""Per-core utilisation plots (PNG) for a fit check."""

from __future__ import annotations

import os
import textwrap
from pathlib import Path

import numpy as np

from neurovpr.fileio import save_figure

from .check import CheckReport

__all__ = ["plot_utilisation"]

_TITLES = {
    "neurons": "neurons",
    "input_axons": "input axons",
    "output_axons": "output axons",
    "synapse_bits": "synapse memory",
}


def plot_utilisation(report: CheckReport, path: str | os.PathLike) -> Path:
    """Write a PNG with one bar per core and one panel per limited resource.

    Bars are grouped and coloured by population; the dashed line marks the per-core
    limit (100 %). Resources without a per-core limit (SpiNNaker's synaptic matrices)
    get a panel in absolute units.

    Parameters
    ----------
    report
        The fit check to draw.
    path
        Where to write the PNG (parent folders are created).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    cores = report.partition.cores
    limited = [k for k in _TITLES if any(k in c.limits for c in cores)]
    absolute = [k for k in ("synaptic_matrix_bytes",) if any(k in c.usage for c in cores)]
    panels = limited + absolute or ["neurons"]
    names = list(dict.fromkeys(c.population for c in cores))
    colours = plt.get_cmap("tab20")(np.linspace(0, 1, max(len(names), 1)))
    colour_of = {n: colours[i % len(colours)] for i, n in enumerate(names)}
    width = min(24.0, 6.0 + 0.08 * len(cores))
    fig, axes = plt.subplots(len(panels), 1, figsize=(width, 2.2 * len(panels) + 1.0), sharex=True, squeeze=False)
    x = np.arange(len(cores))
    for ax, key in zip(axes[:, 0], panels, strict=True):
        if key in limited:
            values = [100.0 * c.usage.get(key, 0) / c.limits[key] if c.limits.get(key) else 0.0 for c in cores]
            ax.axhline(100.0, color="k", linestyle="--", linewidth=0.8)
            ax.set_ylabel(f"{_TITLES[key]} (%)")
        else:
            values = [c.usage.get(key, 0) / 1024.0 for c in cores]
            ax.set_ylabel("synaptic matrix (KiB)")
        ax.bar(x, values, color=[colour_of[c.population] for c in cores], width=0.9)
        ax.grid(axis="y", alpha=0.3)
    handles = [plt.Rectangle((0, 0), 1, 1, color=colour_of[n]) for n in names]
    if handles:
        axes[0, 0].legend(handles, names, ncol=min(6, len(names)), fontsize="small", loc="upper right",
                          framealpha=0.8)
    axes[-1, 0].set_xlabel("core (in placement order)")
    axes[-1, 0].xaxis.set_major_locator(MaxNLocator(integer=True))
    broken = len(report.partition.violations)
    verdict = "fits" if report.fits else f"does not fit ({broken} limit{'s' if broken != 1 else ''} broken)"
    title = f"{report.network} on {report.spec.title}: {len(cores)} cores, {report.partition.chips} chip(s), {verdict}"
    # wrapped to the figure's width (about 11 characters per inch at the default font size), so it is never cut off
    fig.suptitle("\n".join(textwrap.wrap(title, width=max(30, int(11 * width)))))
    fig.tight_layout()
    try:
        return save_figure(fig, path, dpi=100, bbox_inches="tight")
    finally:
        plt.close(fig)
