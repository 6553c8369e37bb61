"""A LoCS-Net run directory: what ``neurovpr train --model locsnet`` writes and ``eval`` reads.

Layout of ``RUN_DIR``::

    network.h5          the converted spiking network (nv.save): the trained weights
    architecture.json   the architecture and the spiking parameters of the conversion
    places.npz          the place labels of the reference frames (arrays only)
    model.pt            the torch state dict before calibration (for fine-tuning)
    run.json            written last: model, backend, seed, data, settings, timing

The trained weights are stored once, in ``network.h5``: with the scale factors of
``architecture.json`` :func:`~.conversion.trained_parameters` recovers them, and checks
on the way that the network has the architecture's populations and shapes. Every
file is written atomically and ``run.json`` last, so a directory with ``run.json`` is
complete. ``model.pt`` holds tensors only; it is read with
``torch.load(weights_only=True)`` and checked name by name against the architecture.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import neurovpr as nv
from neurovpr.apps.rundir import NETWORK_FILE, RunDir
from neurovpr.errors import ValidationError
from neurovpr.fileio import atomic_write_bytes, atomic_write_text

from .architecture import Architecture
from .conversion import SpikingParameters, trained_parameters
from .places import PlaceLabels

__all__ = ["RUN_FORMAT", "FILES", "RunData", "write_run", "load_run", "load_checkpoint", "save_checkpoint"]

#: ``run.json`` format tag of this model.
RUN_FORMAT = "neurovpr-locsnet-run/1"
#: File names inside a run directory.
FILES = {
    "network": NETWORK_FILE,
    "architecture": "architecture.json",
    "labels": "places.npz",
    "checkpoint": "model.pt",
}


@dataclass
class RunData:
    """Everything a finished run holds."""

    path: Path
    info: dict[str, Any]
    arch: Architecture
    spiking: SpikingParameters
    network: nv.Network
    params: dict[str, np.ndarray]
    labels: PlaceLabels


def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def save_checkpoint(path: str | Path, state_dict: dict[str, Any]) -> None:
    """Write a torch state dict (tensors only) atomically."""
    import torch

    buf = io.BytesIO()
    torch.save({k: v.detach().cpu() for k, v in state_dict.items()}, buf)
    atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(path: str | Path, arch: Architecture, place_loss: str = "current") -> dict[str, Any]:
    """Read a state dict with ``weights_only=True`` and check it fits ``arch`` (a clear error otherwise)."""
    import torch

    from .torchnet import LoCSNetTorch, load_state_dict_checked

    path = Path(path)
    if not path.is_file():
        raise ValidationError(f"checkpoint {path} does not exist.")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises many types for a bad file
        raise ValidationError(f"checkpoint {path} is not a readable torch state dict ({type(exc).__name__}).") from None
    model = LoCSNetTorch(arch, place_loss=place_loss)
    load_state_dict_checked(model, state, where=f"checkpoint {path}")
    return state


def write_run(
    out: str | Path,
    *,
    info: dict[str, Any],
    arch: Architecture,
    spiking: SpikingParameters,
    network: nv.Network,
    labels: PlaceLabels,
    state_dict: dict[str, Any] | None,
) -> Path:
    """Write a complete run directory; ``run.json`` (from ``info``) goes last."""
    run = RunDir(out)
    run.save_network(network)
    atomic_write_text(run.part(FILES["architecture"]),
                      json.dumps({"architecture": arch.to_dict(), "spiking": spiking.to_dict()}, indent=2))
    atomic_write_bytes(run.part(FILES["labels"]), _npz_bytes(labels.to_arrays()))
    files = dict(FILES)
    if state_dict is not None:
        save_checkpoint(run.part(FILES["checkpoint"]), state_dict)
    else:
        files.pop("checkpoint")
    record = {"model": "locsnet", "format": RUN_FORMAT, "dt_ms": spiking.dt, **info, "files": files}
    run.write_info(record)
    return run.path


def load_run(run_dir: str | Path) -> RunData:
    """Read and check a run directory (architecture, network, labels)."""
    run = RunDir(run_dir)
    path = run.path
    info = run.read_info()
    if info.get("model") != "locsnet" or info.get("format") != RUN_FORMAT:
        raise ValidationError(
            f"run directory {path} holds a {info.get('model')!r} run of format {info.get('format')!r}, "
            f"not a LoCS-Net run ({RUN_FORMAT})."
        )
    arch_path = run.part(FILES["architecture"])
    try:
        data = json.loads(arch_path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValidationError(f"{arch_path} is not readable JSON ({type(exc).__name__}).") from None
    if not isinstance(data, dict):
        raise ValidationError(f"{arch_path} must hold a JSON object.")
    arch = Architecture.from_dict(data.get("architecture"), where=str(arch_path))
    spiking = SpikingParameters.from_dict(data.get("spiking"), where=f"{arch_path} spiking parameters")
    network = run.load_network()
    params = trained_parameters(network, arch, spiking)
    labels_path = run.part(FILES["labels"])
    try:
        with np.load(labels_path, allow_pickle=False) as npz:
            labels = PlaceLabels.from_arrays({k: npz[k] for k in npz.files})
    except (OSError, ValueError) as exc:
        raise ValidationError(f"{labels_path} is not a readable place-label file ({type(exc).__name__}).") from None
    if labels.n_places != arch.n_places:
        raise ValidationError(
            f"{labels_path} labels {labels.n_places} places but the architecture has {arch.n_places}."
        )
    return RunData(path=path, info=info, arch=arch, spiking=spiking, network=network, params=params, labels=labels)
