"""Interchange with other frameworks' network formats.

:mod:`neurovpr.interop.nir` reads and writes the Neuromorphic Intermediate
Representation (NIR), so graphs move between neurovpr and snnTorch, Norse,
Lava-dl, Rockpool, Sinabs or Spyx.
"""
