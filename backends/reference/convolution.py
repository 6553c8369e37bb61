"""Convolutions delivered from their kernel: which projections qualify, and the arrays the kernels read.

A static projection with a :class:`~neurovpr.ir.connectors.ConvolutionConnector`, one delay
for all its synapses and, for every kernel element, the same weight on every synapse
that uses it (always so when the weights come from a kernel) is *structured*: a spike
of presynaptic neuron ``(c, y, x)`` reaches, for every output position ``(oy, ox)`` whose
receptive field holds it, all ``O`` output channels, with the weights
``kernel[:, c, ky, kx]``. The kernels compute those targets from the neuron's position
and read the weights from the transposed kernel ``(C, kh, kw, O)`` (a few kilobytes,
which stay in cache) instead of one stored target and weight per synapse, which for a
convolutional network are megabytes streamed from memory on every query.

Every other static synapse goes the generic way (:func:`.delivery.static_delivery`).
The synapses of a structured projection stay in the static CSR arrays (``s_*``), which
the weight and connection queries read; setting weights that no longer share a kernel
moves the projection to the generic path (:func:`.delivery.split_static` again).

Results are the same bit for bit as the synapse-by-synapse loop: a spike adds one term
per target, in spike order, and a target receives one term per structured projection.
The one difference in order is for a neuron that reaches the same target at the same
step and receptor through a structured projection and another projection: the
structured term is then added after the other, not in projection order.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from neurovpr.ir.connectors import ConvolutionConnector

from .kernel_layout import (
    CV_C,
    CV_DELAY,
    CV_H,
    CV_KH,
    CV_KW,
    CV_O,
    CV_OH,
    CV_OW,
    CV_PH,
    CV_POST0,
    CV_PRE0,
    CV_PW,
    CV_REC,
    CV_SH,
    CV_SW,
    CV_W,
    CV_WOFF,
    N_CV_COLS,
)


@dataclass(frozen=True)
class ConvSpec:
    """Structured projections delivered as one convolution: parameters and each synapse's kernel element.

    Several projections from the same feature map, with the same geometry, onto
    populations that follow one another (a convolution split into feature groups) are
    one convolution with all their output channels (:func:`merge`). For member ``m``,
    synapse ``k`` (canonical order) uses element ``fields[m][k] * O + channels[m][k]``
    of the transposed, flattened kernel ``(C, kh, kw, O)``.
    """

    names: tuple[str, ...]
    row: np.ndarray
    fields: tuple[np.ndarray, ...]
    channels: tuple[np.ndarray, ...]

    @property
    def size(self) -> int:
        """Number of elements of the transposed kernel."""
        return int(self.row[CV_C] * self.row[CV_KH] * self.row[CV_KW] * self.row[CV_O])

    def kernel(self, weights: Sequence[np.ndarray]) -> np.ndarray | None:
        """The transposed kernel holding each member's ``weights`` (canonical order), or None if they share none."""
        kt = np.zeros(self.size)
        index = [f * self.row[CV_O] + ch for f, ch in zip(self.fields, self.channels, strict=True)]
        for idx, w in zip(index, weights, strict=True):
            kt[idx] = w
        for idx, w in zip(index, weights, strict=True):
            if not np.array_equal(kt[idx].view(np.int64), np.asarray(w, dtype=np.float64).view(np.int64)):
                return None
        return kt


#: The columns two projections must share to be one convolution (all but O, POST0, WOFF).
_SHARED = [CV_PRE0, CV_C, CV_H, CV_W, CV_OH, CV_OW, CV_KH, CV_KW, CV_SH, CV_SW, CV_PH, CV_PW, CV_DELAY, CV_REC]


def merge(specs: Iterable[ConvSpec]) -> list[ConvSpec]:
    """Join consecutive specs that are feature groups of one convolution (see :class:`ConvSpec`)."""
    out: list[ConvSpec] = []
    for spec in specs:
        last = out[-1] if out else None
        plane = int(spec.row[CV_OH] * spec.row[CV_OW])
        if (
            last is not None
            and np.array_equal(last.row[_SHARED], spec.row[_SHARED])
            and spec.row[CV_POST0] == last.row[CV_POST0] + last.row[CV_O] * plane
            and last.row[CV_O] + spec.row[CV_O] < 2**15
        ):
            row = last.row.copy()
            row[CV_O] += spec.row[CV_O]
            channels = (*last.channels, spec.channels[0] + last.row[CV_O])
            out[-1] = ConvSpec(names=(*last.names, *spec.names), row=row, fields=(*last.fields, *spec.fields),
                               channels=channels)  # fmt: skip
        else:
            out.append(spec)
    return out


def conv_spec(
    name: str,
    conn: ConvolutionConnector,
    pre: np.ndarray,
    post: np.ndarray,
    weight: np.ndarray,
    steps: np.ndarray,
    offsets: tuple[int, int],
    inhibitory: bool,
) -> ConvSpec | None:
    """The structured form of a convolution projection, or None where it must go the generic way.

    ``pre``, ``post``, ``weight`` and ``steps`` (delays in steps) are its synapses in
    canonical order; ``offsets`` the first global index of its pre- and postsynaptic
    populations.
    """
    if pre.size == 0 or np.any(steps != steps[0]) or not packable(conn):
        return None
    c, h, w = conn.input_shape
    o, oh, ow = conn.output_shape
    (kh, kw), (sh, sw), (ph, pw) = conn.kernel_shape, conn.stride, conn.padding
    ci, rem = np.divmod(pre, h * w)
    y, x = np.divmod(rem, w)
    oc, rem = np.divmod(post, oh * ow)
    oy, ox = np.divmod(rem, ow)
    ky, kx = y + ph - oy * sh, x + pw - ox * sw
    if ky.min() < 0 or ky.max() >= kh or kx.min() < 0 or kx.max() >= kw:
        return None
    # the kernels visit every (oy, ox) whose field holds (y, x): that must be exactly these synapses
    lo_y, end_y = _span(np.arange(h) + ph, kh, sh, oh)
    lo_x, end_x = _span(np.arange(w) + pw, kw, sw, ow)
    if int((end_y - lo_y).sum() * (end_x - lo_x).sum()) * c * o != pre.size:
        return None
    row = np.array([offsets[0], c, h, w, o, oh, ow, kh, kw, sh, sw, ph, pw, offsets[1], int(steps[0]), int(inhibitory), 0])
    spec = ConvSpec(names=(name,), row=row.astype(np.int64), fields=((ci * kh + ky) * kw + kx,), channels=(oc,))
    return spec if spec.kernel([weight]) is not None else None


def _span(p: np.ndarray, k: int, s: int, n_out: int) -> tuple[np.ndarray, np.ndarray]:
    """Output positions ``lo:end`` along one axis whose field (kernel ``k``, stride ``s``) holds padded input position ``p``."""
    lo = np.minimum(np.maximum(0, -((k - 1 - p) // s)), n_out)  # ceil((p - k + 1) / s), within the output
    return lo, np.maximum(np.minimum(n_out, p // s + 1), lo)


def geometry(row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per presynaptic neuron of a structured projection, its position and the output positions it reaches, packed.

    ``a = c | yy << 20 | xx << 40`` with ``yy = y + pad_h`` and ``xx = x + pad_w``;
    ``b = oy_lo | oy_end << 16 | ox_lo << 32 | ox_end << 48``: the output rows
    ``oy_lo:oy_end`` and columns ``ox_lo:ox_end`` whose field holds the neuron (so the
    kernels divide nothing).
    """
    c, h, w = (int(row[k]) for k in (CV_C, CV_H, CV_W))
    local = np.arange(c * h * w, dtype=np.int64)
    ci, rem = np.divmod(local, h * w)
    y, x = np.divmod(rem, w)
    yy, xx = y + row[CV_PH], x + row[CV_PW]
    oy_lo, oy_end = _span(yy, int(row[CV_KH]), int(row[CV_SH]), int(row[CV_OH]))
    ox_lo, ox_end = _span(xx, int(row[CV_KW]), int(row[CV_SW]), int(row[CV_OW]))
    a = ci | (yy << 20) | (xx << 40)
    b = oy_lo | (oy_end << 16) | (ox_lo << 32) | (ox_end << 48)
    return a, b


def packable(conn: ConvolutionConnector) -> bool:
    """Whether the packed geometry (:func:`geometry`) holds this convolution's sizes."""
    c, h, w = conn.input_shape
    _, oh, ow = conn.output_shape
    ph, pw = conn.padding
    return c < 2**20 and h + ph < 2**20 and w + pw < 2**20 and max(oh, ow) < 2**15


def conv_tables(specs: Iterable[ConvSpec], n: int, s_w: np.ndarray, positions: dict[str, np.ndarray]) -> dict[str, object]:
    """The kernels' arrays for the structured projections.

    ``cv_index``: pointers, then entries of three values: the structured projections
    that presynaptic neuron ``i`` feeds are entries ``cv_index[i]:cv_index[i + 1]``
    (entry ``e`` at ``cv_index[n + 1 + 3 e :]``: projection, then the packed geometry of
    :func:`geometry`); ``cv_par``: a parameter row per projection; ``cv_w``: the
    transposed kernels one after the other (``cv_par[:, CV_WOFF]`` is where each starts).
    """
    specs = list(specs)
    rows, kernels, pres, entries = [], [], [], []
    w_off = 0
    for p, spec in enumerate(specs):
        kt = spec.kernel([s_w[positions[name]] for name in spec.names])
        row = spec.row.copy()
        row[CV_WOFF] = w_off
        w_off += kt.size
        rows.append(row)
        kernels.append(kt)
        a, b = geometry(row)
        pres.append(row[CV_PRE0] + np.arange(a.size, dtype=np.int64))
        entries.append(np.stack([np.full(a.size, p, dtype=np.int64), a, b], axis=1))
    pre = np.concatenate(pres) if pres else np.zeros(0, dtype=np.int64)
    table = np.concatenate(entries) if entries else np.zeros((0, 3), dtype=np.int64)
    order = np.lexsort((table[:, 0], pre))
    ptr = np.concatenate([[0], np.cumsum(np.bincount(pre, minlength=n))])
    return {
        "cv_index": np.concatenate([ptr, table[order].ravel()]).astype(np.int64),
        "cv_par": np.ascontiguousarray(np.array(rows, dtype=np.int64).reshape(-1, N_CV_COLS)),
        "cv_w": np.concatenate(kernels) if kernels else np.zeros(0),
    }
