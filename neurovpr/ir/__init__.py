"""The graph IR: small frozen dataclasses for cell types, connectors, synapses and networks.

- :mod:`.node` -- the base of every IR dataclass (validation, arrays, ``replace``)
- :mod:`.cells` -- neuron models and spike sources (PyNN's names, defaults and units)
- :mod:`.connectors`, :mod:`.synapses`, :mod:`.distributions` -- how populations connect and learn
- :mod:`.network` -- populations, projections and the graph that holds them
- :mod:`.connectivity` -- connectors expanded into concrete ``(pre, post)`` connections
- :mod:`.serialization` -- one versioned HDF5 file per network, derived from the fields

The public names are re-exported as ``neurovpr.*`` (``nv.Network``, ``nv.IF_cond_exp`` ...).
"""
