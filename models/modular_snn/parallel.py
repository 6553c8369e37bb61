"""Running module jobs in parallel: a local process pool, a Dask cluster, or in-process.

Every module (of every ensemble member) is an independent job whose randomness comes
only from its own seed, derived from ``(seed, member, module)``, so the result of a run
does not depend on where or in which order its jobs ran. A job returns its result as
bytes (the learned network as a neurovpr HDF5 file, the records as ``.npz``); the
calling process writes each one atomically as soon as it arrives, which is what makes
an interrupted run resumable (see :mod:`.runs`). Nothing is pickled to disk; the pool
and Dask move arguments and results between processes with their own transport.

- ``scheduler=None, workers > 1``: ``concurrent.futures.ProcessPoolExecutor`` (spawned
  processes, so no thread or lock state is inherited; a script that trains with
  several workers must therefore guard its entry with ``if __name__ == "__main__":``).
- ``scheduler="tcp://HOST:PORT"``: ``dask.distributed.Client`` on that scheduler; large
  shared arrays are scattered to the workers once. Workers need neurovpr installed and
  no shared file system.
- ``workers <= 1`` and no scheduler: jobs run one after another in this process.
"""

from __future__ import annotations

import io
import json
import multiprocessing
import os
import tempfile
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

import neurovpr as nv

from .inference import reference_activity
from .training import Presenter, TrainingSettings, module_seeds, record_responses, train_module

__all__ = ["default_workers", "run_jobs", "train_job", "query_job", "npz_bytes", "read_npz"]


def default_workers() -> int:
    """Number of CPU cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def npz_bytes(**arrays: Any) -> bytes:
    """An uncompressed ``.npz`` file's bytes (plain arrays only, never objects)."""
    buf = io.BytesIO()
    np.savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    return buf.getvalue()


def read_npz(path: str | Path) -> dict[str, np.ndarray]:
    """Read an ``.npz`` written by :func:`npz_bytes` (``allow_pickle=False``)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError) as exc:
        raise nv.FileFormatError(f"{path} is not a readable module record ({exc}).") from None


def _network_bytes(network: nv.Network) -> bytes:
    with tempfile.TemporaryDirectory(prefix="neurovpr-module-") as tmp:
        path = Path(tmp) / "module.h5"
        nv.save(network, path)
        return path.read_bytes()


def _network_from_bytes(data: bytes) -> nv.Network:
    with tempfile.TemporaryDirectory(prefix="neurovpr-module-") as tmp:
        path = Path(tmp) / "module.h5"
        path.write_bytes(data)
        return nv.load(path)


def train_job(
    reference: np.ndarray,
    settings: str,
    name: str,
    places: np.ndarray,
    seed: int,
    fingerprint: str,
    n_traverses: int = 1,
    network_seed: int | None = None,
    stream_seed: int | None = None,
) -> dict[str, Any]:
    """Train one module and return its files' bytes (runs in a worker).

    ``settings`` is :meth:`TrainingSettings.as_dict` as JSON (plain data crosses
    process boundaries). ``reference`` holds the ``n_traverses`` training traverses'
    images one after another (``(n_traverses * N, pixels)``, the reference first).
    The record holds the module's places, its mean responses to them over the last
    training presentations (``own_responses``, for the assignment, see
    :func:`.training.train_module`), the total spikes and the number of reference images
    each neuron fired for with learning off, over the images of the first (main)
    reference traverse, as VPRSNN's ``record`` mode counts them (``total_spikes``,
    ``images_fired``, for hyperactive-neuron detection; ``n_traverses`` says how many
    traverses were trained on), the seeds (``network_seed`` and ``stream_seed``: ``seed``
    when not given, see :mod:`.plan`), the timing and the job's fingerprint.
    """
    cfg = TrainingSettings.from_dict(json.loads(settings))
    places = np.asarray(places, dtype=np.int64)
    t = int(n_traverses)
    if t < 1 or len(reference) % t:
        raise nv.ValidationError(f"module {name!r}: {len(reference)} training images cannot be {t} traverses of equal length.")
    n_ref = len(reference) // t
    traverses = [reference[k * n_ref : (k + 1) * n_ref] for k in range(t)]
    weights, stream = module_seeds(seed, network_seed, stream_seed)
    network, own, responses, timing = train_module(
        traverses[0], places, cfg, seed, name=name, extra_references=traverses[1:], network_seed=network_seed,
        stream_seed=stream_seed,
    )
    main = responses[:n_ref]
    record = npz_bytes(
        places=places,
        own_responses=own,
        total_spikes=reference_activity(main, measure="spikes"),
        images_fired=reference_activity(main, measure="images"),
        n_traverses=np.int64(t),
        theta=network.populations["exc"].cell_type.theta_init,
        seed=np.int64(seed),
        network_seed=np.int64(weights),
        stream_seed=np.int64(stream),
        **{key: np.float64(value) for key, value in timing.items()},
        n_presentations=np.int64(t * (cfg.epochs * places.size + n_ref)),
        fingerprint=np.str_(fingerprint),
    )
    return {"name": name, "network": _network_bytes(network), "record": record, "timing": timing}


def query_job(images: np.ndarray, settings: str, backend: str, options: str, network: bytes, seed: int) -> np.ndarray:
    """Spike counts ``(n_images, n_neurons)`` of a learned module for ``images`` (runs in a worker).

    ``options`` are the backend's options as a JSON object (``"{}"``: its defaults).
    """
    from .deployment import static_network

    cfg = TrainingSettings.from_dict(json.loads(settings))
    net = _network_from_bytes(network)
    if not nv.get_backend(backend).capabilities.learns:  # an inference backend (torch) runs the learned weights as static
        net = static_network(net)
    sim = nv.compile(net, backend=backend, dt=cfg.dt, seed=int(seed), **json.loads(options))
    sim.plasticity(False)
    flat = np.asarray(images).reshape(len(images), -1)
    return record_responses(Presenter(sim, cfg), flat)


def run_jobs(
    fn: Callable[..., Any],
    shared: np.ndarray,
    jobs: Sequence[tuple[Any, ...]],
    on_result: Callable[[int, Any], None],
    *,
    workers: int,
    scheduler: str | None = None,
    progress: Iterable[Any] | None = None,
) -> None:
    """Call ``fn(shared, *job)`` for every job and ``on_result(index, result)`` as each finishes.

    ``progress`` is an object with ``update(n)`` (a tqdm bar) or ``None``.
    """
    if not jobs:
        return
    tick = getattr(progress, "update", None)
    if scheduler:
        _run_dask(fn, shared, jobs, on_result, scheduler, tick)
    elif workers <= 1:
        for i, job in enumerate(jobs):
            on_result(i, fn(shared, *job))
            if tick:
                tick(1)
    else:
        ctx = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=ctx) as pool:
            futures = {pool.submit(fn, shared, *job): i for i, job in enumerate(jobs)}
            try:
                for fut in as_completed(futures):
                    on_result(futures[fut], fut.result())
                    if tick:
                        tick(1)
            except BaseException:
                for fut in futures:
                    fut.cancel()
                raise


def _run_dask(
    fn: Callable[..., Any],
    shared: np.ndarray,
    jobs: Sequence[tuple[Any, ...]],
    on_result: Callable[[int, Any], None],
    scheduler: str,
    tick: Callable[[int], Any] | None,
) -> None:
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise nv.BackendUnavailableError(
            "--scheduler needs Dask distributed, which is not installed; install it with: pip install 'neurovpr[distributed]'."
        ) from None
    try:
        client = Client(scheduler, timeout=30)
    except (OSError, TimeoutError, ValueError) as exc:
        raise nv.ValidationError(f"cannot connect to the Dask scheduler at {scheduler!r} ({exc}).") from None
    with client:
        shared_future = client.scatter(shared, broadcast=True)
        futures = {client.submit(fn, shared_future, *job, pure=False): i for i, job in enumerate(jobs)}
        try:
            for fut in dask_completed(list(futures)):
                on_result(futures[fut], fut.result())
                if tick:
                    tick(1)
        except BaseException:
            client.cancel(list(futures))
            raise
