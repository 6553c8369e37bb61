"""Expansion of a projection into explicit connections.

Every backend builds its synapses from :func:`expand`, so the same network, seed
and time step give the same connections, weights and delays everywhere. The
*canonical order* of a projection's connections, used by 1-D weight arrays,
``Simulation.weights(..., format="list")`` and saved learned weights, is the row
order for :class:`~neurovpr.ir.connectors.FromListConnector` and ``(pre, post)``
lexicographic order for every other connector.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from neurovpr.errors import ValidationError
from neurovpr.ir.connectors import (
    AllToAllConnector,
    ConvolutionConnector,
    FixedNumberPreConnector,
    FixedProbabilityConnector,
    FromListConnector,
    OneToOneConnector,
)
from neurovpr.ir.distributions import Distribution
from neurovpr.ir.network import Network, Projection

__all__ = [
    "Connections",
    "expand",
    "projection_rng",
    "stream_rng",
    "resolved_seed",
    "CONNECT",
    "WEIGHT",
    "DELAY",
    "POISSON",
]

#: Purposes of the independent random streams: a projection draws its connections,
#: weights and delays from three streams, a ``SpikeSourcePoisson`` population its
#: spikes from a fourth (every backend that draws Poisson spikes on the host uses it).
CONNECT, WEIGHT, DELAY, POISSON = 0, 1, 2, 3


@dataclass(frozen=True, slots=True)
class Connections:
    """Explicit connections of one projection, in canonical order.

    Attributes
    ----------
    pre, post : numpy.ndarray
        ``int64`` indices into the pre- and postsynaptic populations.
    weight : numpy.ndarray
        ``float64`` weights (uS or nA).
    delay : numpy.ndarray
        ``float64`` delays in ms (``None`` delays resolved to ``dt``).
    """

    pre: np.ndarray
    post: np.ndarray
    weight: np.ndarray
    delay: np.ndarray

    def __len__(self) -> int:
        return int(self.pre.size)


def resolved_seed(projection: Projection, seed: int) -> int:
    """The seed the projection's random connector uses: its own if set, else ``seed``."""
    own = getattr(projection.connector, "seed", None)
    return int(own) if own is not None else int(seed)


def stream_rng(name: str, seed: int, purpose: int) -> np.random.Generator:
    """A generator for one purpose of one named projection or population, independent of all others.

    Parameters
    ----------
    name
        The projection's or population's name.
    seed
        The seed the stream derives from (the compile seed, or a connector's own).
    purpose
        :data:`CONNECT`, :data:`WEIGHT`, :data:`DELAY` or :data:`POISSON`.
    """
    key = zlib.crc32(name.encode("utf-8"))
    return np.random.default_rng(np.random.SeedSequence(entropy=int(seed), spawn_key=(key, purpose)))


def projection_rng(projection: Projection, seed: int, purpose: int) -> np.random.Generator:
    """A generator for one purpose of one projection, independent of all others."""
    return stream_rng(projection.name, resolved_seed(projection, seed), purpose)


def _indices(proj: Projection, n_pre: int, n_post: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    conn = proj.connector
    if isinstance(conn, AllToAllConnector):
        pre, post = np.divmod(np.arange(n_pre * n_post, dtype=np.int64), n_post)
        if not conn.allow_self_connections:
            keep = pre != post
            pre, post = pre[keep], post[keep]
        return pre, post
    if isinstance(conn, OneToOneConnector):
        idx = np.arange(n_pre, dtype=np.int64)
        return idx, idx.copy()
    if isinstance(conn, FromListConnector):
        cl = conn.conn_list
        return cl[:, 0].astype(np.int64), cl[:, 1].astype(np.int64)
    if isinstance(conn, FixedProbabilityConnector):
        rng = projection_rng(proj, seed, CONNECT)
        pres, posts = [], []
        for i in range(n_pre):  # row by row keeps memory at O(n_post)
            row = np.flatnonzero(rng.random(n_post) < conn.p_connect)
            if not conn.allow_self_connections:
                row = row[row != i]
            pres.append(np.full(row.size, i, dtype=np.int64))
            posts.append(row.astype(np.int64))
        if not pres:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        return np.concatenate(pres), np.concatenate(posts)
    if isinstance(conn, FixedNumberPreConnector):
        return _fixed_number_pre(proj, conn, n_pre, n_post, seed)
    if isinstance(conn, ConvolutionConnector):
        return _convolution_indices(conn)
    raise ValidationError(f"Projection {proj.name!r}: unknown connector {type(conn).__name__}.")


def _fixed_number_pre(
    proj: Projection, conn: FixedNumberPreConnector, n_pre: int, n_post: int, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    rng = projection_rng(proj, seed, CONNECT)
    if isinstance(conn.n, Distribution):
        counts = np.rint(conn.n.sample(rng, n_post)).astype(np.int64)
    else:
        counts = np.full(n_post, conn.n, dtype=np.int64)
    pres, posts = [], []
    for j in range(n_post):
        candidates = np.arange(n_pre, dtype=np.int64)
        if not conn.allow_self_connections and j < n_pre:
            candidates = candidates[candidates != j]
        limit = candidates.size
        k = int(np.clip(counts[j], 0, None if conn.with_replacement else limit))
        if k and limit:
            chosen = rng.choice(candidates, size=k, replace=conn.with_replacement)
            pres.append(np.sort(chosen))
            posts.append(np.full(k, j, dtype=np.int64))
    if not pres:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(pres), np.concatenate(posts)


def _convolution_indices(conn: ConvolutionConnector) -> tuple[np.ndarray, np.ndarray]:
    c_in, h, w = conn.input_shape
    kh, kw = conn.kernel_shape
    sh, sw = conn.stride
    ph, pw = conn.padding
    oc, oh, ow = conn.output_shape
    o, c, ky, kx, y, x = np.meshgrid(
        np.arange(oc), np.arange(c_in), np.arange(kh), np.arange(kw), np.arange(oh), np.arange(ow), indexing="ij"
    )
    iy = y * sh - ph + ky
    ix = x * sw - pw + kx
    valid = (iy >= 0) & (iy < h) & (ix >= 0) & (ix < w)
    pre = (c * h * w + iy * w + ix)[valid].astype(np.int64)
    post = (o * oh * ow + y * ow + x)[valid].astype(np.int64)
    return pre, post


def _kernel_index(conn: ConvolutionConnector, pre: np.ndarray, post: np.ndarray) -> tuple[np.ndarray, ...]:
    """The kernel element ``(o, c, ky, kx)`` that each convolution connection uses."""
    _, h, w = conn.input_shape
    _, oh, ow = conn.output_shape
    o, rem = np.divmod(post, oh * ow)
    y, x = np.divmod(rem, ow)
    c, rem_in = np.divmod(pre, h * w)
    iy, ix = np.divmod(rem_in, w)
    ky = iy - (y * conn.stride[0] - conn.padding[0])
    kx = ix - (x * conn.stride[1] - conn.padding[1])
    return o, c, ky, kx


def _values(
    proj: Projection, attr: str, spec: object, pre: np.ndarray, post: np.ndarray, seed: int, purpose: int
) -> np.ndarray:
    n = pre.size
    if isinstance(spec, float):
        return np.full(n, spec)
    if isinstance(spec, Distribution):
        return spec.sample(projection_rng(proj, seed, purpose), n).astype(np.float64)
    assert isinstance(spec, np.ndarray)
    if spec.ndim == 4 and isinstance(proj.connector, ConvolutionConnector):
        return spec[_kernel_index(proj.connector, pre, post)].astype(np.float64)
    if spec.ndim == 2:
        return spec[pre, post].astype(np.float64)
    if spec.size != n:
        raise ValidationError(
            f"Projection {proj.name!r}: 1-D {attr} array has {spec.size} values for {n} connections."
        )
    return spec.astype(np.float64, copy=True)


def expand(network: Network, projection: Projection | str, *, dt: float, seed: int) -> Connections:
    """Expand one projection of ``network`` into explicit connections.

    Parameters
    ----------
    network
        The network the projection belongs to (for population sizes).
    projection
        The projection or its name.
    dt
        Simulation time step (ms); a ``None`` delay becomes ``dt``, and a delay
        shorter than ``dt`` is an error.
    seed
        The compile seed (a connector's own ``seed`` takes precedence).

    Returns
    -------
    Connections
        Indices, weights and delays in canonical order.
    """
    proj = network.projections[projection] if isinstance(projection, str) else projection
    n_pre = network.populations[proj.pre].size
    n_post = network.populations[proj.post].size
    pre, post = _indices(proj, n_pre, n_post, seed)
    if not isinstance(proj.connector, FromListConnector):
        order = np.lexsort((post, pre))
        pre, post = pre[order], post[order]
    syn = proj.synapse
    cl = proj.connector.conn_list if isinstance(proj.connector, FromListConnector) else None
    if cl is not None and cl.shape[1] >= 3:
        weight = cl[:, 2].astype(np.float64)
    else:
        weight = _values(proj, "weight", syn.weight, pre, post, seed, WEIGHT)
    if cl is not None and cl.shape[1] == 4:
        delay = cl[:, 3].astype(np.float64)
    elif syn.delay is None:
        delay = np.full(pre.size, float(dt))
    else:
        delay = _values(proj, "delay", syn.delay, pre, post, seed, DELAY)
    short = delay[(delay != 0) & (delay < dt * (1 - 1e-9))]
    if short.size:
        raise ValidationError(
            f"Projection {proj.name!r}: delay {short.min():g} ms is shorter than the time step {dt:g} ms (and not 0)."
        )
    bounds = syn.weight_bounds
    if bounds is not None and weight.size and (weight.min() < bounds[0] or weight.max() > bounds[1]):
        weight = np.clip(weight, *bounds)
    return Connections(pre=pre, post=post, weight=weight, delay=delay)
