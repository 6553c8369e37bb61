"""numba's on-disk cache for kernels whose code comes from several files.

numba keys a cached function on the modification time and size of its own source file and
on hashes of its bytecode and of the contents of its closure (numba/core/caching.py:
``IndexDataCacheFile`` checks the file's stamp, ``FunctionCache._index_key`` hashes the
bytecode and the closure). A helper or a constant the function takes from another file is
compiled into its machine code but is in none of these, so a change to that file would load
the old machine code. A cached kernel of this backend whose code comes from several files is
therefore made by a function that closes over :func:`source_stamp` of all of them and names
it in its body, which puts the stamp in the closure and so in the key: a change to any of the
files compiles the kernel anew. The helpers such a kernel calls are not cached on their own
(their cache would have the same blind spot); compiled into the kernel, they are cached with
it. tests/backends/test_reference_kernel_cache.py checks that every cached kernel of the
package is keyed on every file its code comes from.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from pathlib import Path


def source_stamp(module_file: str, modules: Iterable[str]) -> int:
    """A 60-bit hash of the sources of ``modules``, the names (without ``.py``) of files beside ``module_file``.

    Parameters
    ----------
    module_file
        The ``__file__`` of a module in the same directory.
    modules
        The module names; order and repetition do not matter.

    Returns
    -------
    int
        The first 60 bits of the SHA-256 of the names and contents (an integer, so that a
        kernel compiled without numba's reference counting can hold it).
    """
    digest = hashlib.sha256()
    here = Path(module_file).parent
    for name in sorted(set(modules)):
        digest.update(name.encode() + b"\0" + (here / f"{name}.py").read_bytes() + b"\0")
    return int(digest.hexdigest()[:15], 16)
