"""``exp`` for the numba kernels, called straight from the C math library.

numba compiles ``np.exp`` of a float to a call into its helper library, which calls the C
library's ``exp`` as numba's own build linked it: with glibc that is the old symbol version
``exp@GLIBC_2.2.5``, a compatibility wrapper (SVID error handling) around the same core
function that the current default version ``exp`` calls directly. The result is the same
number (the wrapper only acts on overflow and underflow, where it returns the same
infinity or zero); the two extra calls cost about 1.5 ns of the 6 ns an ``exp`` takes here,
and the conductance neurons call it once per neuron and step. :func:`exp` is that direct
call: the default ``exp`` of the process's math library, registered with LLVM under
``SYMBOL`` when this module is imported (before any kernel that calls it is compiled or
loaded from numba's cache). ``tests/backends/test_reference_libm.py`` checks that it returns
``np.exp``'s bits in numba.
"""

from __future__ import annotations

import ctypes
import ctypes.util

import llvmlite.binding as llvm
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

#: The name the kernels' machine code calls (registered with LLVM's symbol table).
SYMBOL = "neurovpr_reference_exp"

_LIBM = ctypes.CDLL(ctypes.util.find_library("m"))
llvm.add_symbol(SYMBOL, ctypes.cast(_LIBM.exp, ctypes.c_void_p).value)


@intrinsic
def exp(typingctx, x):  # type: ignore[no-untyped-def]
    """``exp(x)`` of a float64 by the C library's default ``exp`` (the same bits as ``np.exp`` in numba)."""
    if not isinstance(x, types.Float):
        return None
    sig = types.float64(x)

    def codegen(context, builder, signature, args):  # type: ignore[no-untyped-def]
        arg = context.cast(builder, args[0], signature.args[0], types.float64)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.DoubleType(), [ir.DoubleType()]), SYMBOL)
        return builder.call(fn, [arg])

    return sig, codegen
