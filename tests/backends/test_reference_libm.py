"""The kernels' exp (backends/reference/libm.py) returns numba's np.exp bits, so no spike or weight moves.

It calls the C library's default exp directly instead of going through numba's helper and
glibc's compatibility wrapper; the two must agree everywhere, including where exp overflows,
underflows to 0 or to a subnormal, and at the special values.
"""

from __future__ import annotations

import numpy as np
import pytest

numba = pytest.importorskip("numba")
libm = pytest.importorskip("neurovpr.backends.reference.libm")


@numba.njit
def _direct(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.size):
        out[i] = libm.exp(x[i])


@numba.njit
def _numba(x: np.ndarray, out: np.ndarray) -> None:
    for i in range(x.size):
        out[i] = np.exp(x[i])


def test_direct_exp_equals_numba_exp_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    special = [0.0, -0.0, np.inf, -np.inf, np.nan, 709.78, 709.79, -708.39, -745.13, -745.14, 5e-324, -5e-324, 1e-300]
    x = np.concatenate([special, rng.uniform(-1.0, 0.0, 200_000), rng.uniform(-800.0, 800.0, 200_000),
                        -np.exp(rng.uniform(-30, 6.6, 100_000))])  # fmt: skip
    ours, theirs = np.empty_like(x), np.empty_like(x)
    _direct(x, ours)
    _numba(x, theirs)
    same = (ours.view(np.int64) == theirs.view(np.int64)) | (np.isnan(ours) & np.isnan(theirs))
    assert np.all(same), x[~same][:5]
    assert ours[2] == np.inf and ours[3] == 0.0 and ours[0] == 1.0


def test_the_symbol_is_registered_for_cached_kernels() -> None:
    """A kernel loaded from numba's cache links the name at load time: it must be known to LLVM."""
    import llvmlite.binding as llvm

    assert llvm.address_of_symbol(libm.SYMBOL)
