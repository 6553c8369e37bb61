"""Map a network onto a virtual SpiNN-5 board with sPyNNaker's own toolchain.

:func:`map_network` runs sPyNNaker's real partitioning, placement, routing and data
generation on a virtual board (sPyNNaker's configuration for running without
hardware) and reports what sPyNNaker says the network uses. Each call writes
sPyNNaker's configuration and reports into a fresh temporary folder, points
``XDG_CONFIG_HOME`` and ``HOME`` at it for the duration of the call (so that nothing
is read from or written to the user's home), restores them and removes the folder.

sPyNNaker only maps when asked to run: the mapping runs one time step, which on a
virtual board produces no spikes. sPyNNaker runs a whole number of microseconds per
step, ``dt`` rounded up (:func:`neurovpr.hardware.spinnaker.spynnaker_step_us`); its
default minimum delay is ``dt`` itself, which it refuses when ``dt`` is not a whole
number of microseconds, so the minimum delay given is one of its steps. sPyNNaker keeps global state, so map one network
at a time per process.
"""

from __future__ import annotations

import atexit
import contextlib
import importlib
import io
import logging
import math
import numbers
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Iterator
from types import ModuleType
from typing import Any

from neurovpr.errors import NeurovprError, UnsupportedFeatureError, ValidationError
from neurovpr.hardware.spinnaker import spynnaker_step_us
from neurovpr.ir.network import Network
from neurovpr.runtime.backend import capability_problems

from .capabilities import CAPABILITIES
from .translation import build_network

__all__ = ["map_network", "silenced"]

_LOGGERS = ("spinn_utilities", "spinn_machine", "spinnman", "pacman", "spinn_front_end_common", "spynnaker", "pyNN")


@contextlib.contextmanager
def _private_config() -> Iterator[str]:
    """A temporary folder holding the virtual-board configuration, used as the config and home folder."""
    root = tempfile.mkdtemp(prefix="neurovpr-spynnaker-")
    config, home, reports = (os.path.join(root, name) for name in ("config", "home", "reports"))
    for folder in (config, home, reports):
        os.makedirs(folder)
    with open(os.path.join(config, ".spynnaker.cfg"), "w", encoding="utf-8") as f:
        f.write(f"[Machine]\nvirtual_board = True\nversion = 5\n\n[Reports]\ndefault_report_file_path = {reports}\n")
    saved = {key: os.environ.get(key) for key in ("XDG_CONFIG_HOME", "HOME")}
    os.environ["XDG_CONFIG_HOME"] = config
    os.environ["HOME"] = home
    try:
        yield root
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        shutil.rmtree(root, ignore_errors=True)


@contextlib.contextmanager
def silenced() -> Iterator[None]:
    """Keep sPyNNaker's progress bars, log lines and warnings off the terminal."""
    levels = {name: logging.getLogger(name).level for name in _LOGGERS}
    for name in _LOGGERS:
        logging.getLogger(name).setLevel(logging.ERROR)
    sink = io.StringIO()
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            warnings.simplefilter("ignore")
            yield
    finally:
        for name, level in levels.items():
            logging.getLogger(name).setLevel(level)


def _import() -> tuple[ModuleType, Any]:
    with silenced():
        sim = importlib.import_module("spynnaker.pyNN")
        view = importlib.import_module("spynnaker.pyNN.data").SpynnakerDataView
    return sim, view


def _sentence(network: Network, n_boards: int, exc: BaseException) -> str:
    """sPyNNaker's reason as one sentence."""
    text = str(exc).strip() or type(exc).__name__
    text = text.split("Report written to", 1)[0]
    text = re.sub(r"(?<=[a-z])(?=Setup asked for)", ". ", text)
    text = " ".join(text.split()).rstrip(" .")
    boards = "one SpiNN-5 board" if n_boards == 1 else f"{n_boards} SpiNN-5 boards"
    return f"sPyNNaker cannot map network {network.name!r} onto {boards}: {type(exc).__name__}: {text}."


def _kind(vertex: Any) -> str:
    name = type(vertex).__name__
    if "Delay" in name:
        return "delays"
    if "Synapses" in name:
        return "synapses"
    if "SpikeSource" in name:
        return "source"
    return "neurons"


def _matrix_bytes(vertex: Any) -> int | None:
    """SDRAM of the core's synaptic matrix region, or ``None`` for a core without one."""
    regions = getattr(type(vertex), "SYNAPSE_REGIONS", None)
    cost = getattr(vertex.sdram_required, "regions", {}).get(getattr(regions, "synaptic_matrix", None))
    return None if cost is None else int(cost.get_total_sdram(0))


def _placements(view: Any, names: set[str]) -> list[dict[str, Any]]:
    """One row per core holding a population, in the order sPyNNaker placed them."""
    n_steps = view.get_plan_n_timestep()
    rows = []
    for placement in view.iterate_placemements():  # sic: sPyNNaker's spelling
        vertex = placement.vertex
        app = getattr(vertex, "app_vertex", None)
        label = getattr(app, "label", None)
        if label not in names:
            label = getattr(getattr(app, "source_vertex", None), "label", None)
        if label not in names:
            continue  # sPyNNaker's own system cores (monitors, gatherers)
        vertex_slice = vertex.vertex_slice
        rows.append(
            {
                "population": label,
                "lo_atom": int(vertex_slice.lo_atom),
                "hi_atom": int(vertex_slice.hi_atom),
                "x": int(placement.x),
                "y": int(placement.y),
                "p": int(placement.p),
                "sdram_bytes": int(vertex.sdram_required.get_total_sdram(n_steps)),
                "synaptic_matrix_bytes": _matrix_bytes(vertex),
                "kind": _kind(vertex),
                "vertex": type(vertex).__name__,
            }
        )
    return rows


def map_network(network: Network, *, dt: float, seed: int, n_boards: int = 1) -> dict[str, Any]:
    """Partition, place and route ``network`` with sPyNNaker on ``n_boards`` virtual SpiNN-5 boards.

    Parameters
    ----------
    network
        The network to map.
    dt
        Time step (ms), sPyNNaker's ``timestep``.
    seed
        Seed of the connectivity expansion (the mapped connections are the canonical ones).
    n_boards
        Number of SpiNN-5 boards sPyNNaker may use (``n_boards_required``).

    Returns
    -------
    dict
        ``chips`` and ``cores``: chips and cores holding the network's populations
        (sPyNNaker's own monitor cores on every chip are not counted);
        ``sdram_bytes``: SDRAM those cores need; ``placements``: one row per core, in
        the order sPyNNaker placed them, with ``population``, ``lo_atom``, ``hi_atom``
        (inclusive), ``x``, ``y``, ``p``, ``sdram_bytes``, ``synaptic_matrix_bytes``
        (the core's synaptic matrix region, ``None`` for cores without synapses),
        ``kind`` (``neurons``, ``synapses``, ``source`` or ``delays``) and ``vertex``
        (sPyNNaker's machine-vertex class); ``machine_chips``: chips of the virtual
        machine; ``timestep_ms``: ``dt``; ``machine_timestep_us``: the step sPyNNaker
        runs, ``dt`` rounded up to whole microseconds.

    Raises
    ------
    UnsupportedFeatureError
        If the network uses a type sPyNNaker cannot map.
    ValidationError
        If sPyNNaker cannot map the network (it does not fit, or sPyNNaker rejects a
        value); the message carries sPyNNaker's own reason in one sentence.
    """
    if not isinstance(network, Network):
        raise ValidationError(f"map_network: expected a neurovpr Network, got {type(network).__name__}.")
    if isinstance(dt, bool) or not isinstance(dt, numbers.Real) or not math.isfinite(dt) or dt <= 0:
        raise ValidationError(f"map_network: dt must be a positive number of ms, got {dt!r}.")
    if isinstance(n_boards, bool) or not isinstance(n_boards, numbers.Integral) or n_boards < 1:
        raise ValidationError(f"map_network: n_boards must be an integer >= 1, got {n_boards!r}.")
    problems = capability_problems(CAPABILITIES, network)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise UnsupportedFeatureError(f"Backend 'spinnaker' cannot map {problems[0]}{more}.")
    sim, view = _import()
    step_us = spynnaker_step_us(dt)
    with _private_config(), silenced():
        try:
            sim.setup(timestep=float(dt), min_delay=step_us / 1000.0, n_boards_required=int(n_boards))
            if view.get_simulation_time_step_us() != step_us:
                raise ValidationError(
                    f"map_network: sPyNNaker runs dt={dt!r} ms as {view.get_simulation_time_step_us()} us, "
                    f"not the {step_us} us neurovpr.hardware.spinnaker.spynnaker_step_us expects."
                )
            build_network(sim, network, dt=float(dt), seed=seed)
            sim.run(view.get_simulation_time_step_ms())
            placements = _placements(view, set(network.populations))
            machine_chips = int(view.get_machine().n_chips)
        except NeurovprError:
            raise
        except Exception as exc:  # sPyNNaker raises many types; each becomes one sentence
            raise ValidationError(_sentence(network, n_boards, exc)) from exc
        finally:
            with contextlib.suppress(Exception):
                sim.end()
            # sPyNNaker registers an exit hook per run that writes into the report
            # folder, which is removed on return
            writer = importlib.import_module("spinn_utilities.data.utils_data_writer").UtilsDataWriter
            atexit.unregister(writer.write_errored_file)
    return {
        "chips": len({(r["x"], r["y"]) for r in placements}),
        "cores": len(placements),
        "sdram_bytes": sum(r["sdram_bytes"] for r in placements),
        "placements": placements,
        "machine_chips": machine_chips,
        "timestep_ms": float(dt),
        "machine_timestep_us": step_us,
    }
