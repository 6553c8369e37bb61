"""The backend kit: what every backend needs and would otherwise write again.

A backend (``backends/<name>/`` in this repository, or a third-party package declaring a
``neurovpr.backends`` entry point) builds on these modules instead of copying another
backend:

- :mod:`.capabilities` -- building blocks of a capability declaration (the IR's type
  names by family) and of a backend declaration (options with defaults, quiet imports);
- :mod:`.timing` -- delays and spike times on the step grid of docs/semantics.md;
- :mod:`.sources` -- spike sources drawn on the host, and their seeding;
- :mod:`.lif` -- an ``IF_curr_exp`` population as a normalised compartment (threshold 1,
  reset 0), the form Nengo, Lava and Loihi compute in;
- :mod:`.loihi2` -- that compartment and its synapse groups as Loihi 2's integers, with the
  limits of a hwspec's ``[formats]`` (Lava's ``fixed_pt`` models and the ``loihi2`` emulation);
- :mod:`.readout` -- spike counts, spike trains and activity counts read back from rasters;
- :mod:`.chips` -- the fit of a network on the chip a backend stands for (``xylo``, ``speck``),
  a misfit refused as an unsupported feature;
- :mod:`.hosted` -- a :class:`~neurovpr.runtime.simulation.Simulation` base for backends
  that run neurovpr's expanded connections and read spikes back as rasters;
- :mod:`.pynn_names` -- the PyNN and sPyNNaker names of the IR's types.

The kit depends on the IR and the runtime only; nothing in it imports a simulator.
"""
