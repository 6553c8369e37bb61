"""The backend conformance suite, shipped with neurovpr as a pytest plugin.

The same small networks, with analytic answers derived from ``docs/semantics.md``, run on
every backend the ``neurovpr.backends`` entry point declares. A backend package outside
neurovpr runs the suite against its own entry point::

    pytest --pyargs neurovpr.conformance --neurovpr-backend mybackend -rs

(``--neurovpr-backend`` may be repeated or take ``a,b``; the ``NEUROVPR_BACKENDS``
environment variable selects the same way; with neither, every declared backend runs).
The option comes from neurovpr's pytest plugin (:mod:`.plugin`, the ``pytest11`` entry
point), which is all that loads in other test sessions. Nengo's own plugin needs
``pytest<8``; with Nengo installed add ``-p no:nengo``.

A backend declares, in its :class:`~neurovpr.runtime.backend.Capabilities`:

- what it runs (cell types, connectors, synapses, learning, recordables, heterogeneous
  delays): a case needing anything else skips, naming what is missing;
- ``unsupported``: ``{case_id: reason}`` for cases it cannot pass (the case skips with
  the reason; :mod:`.cases` lists the ids);
- ``tolerances``: ``{case_id: ToleranceOverride(changes, reason)}`` where its numerics
  legitimately differ from exact integration (:mod:`.tolerances` has the default bounds;
  ``test_declarations.py`` checks every override only loosens a known bound and gives
  its reason).

A backend declared but not usable here (its simulator does not import, or it only maps
networks) is reported as skipped with the registry's reason.

- :mod:`.cases` -- the case ids and what each checks
- :mod:`.analytic` -- the closed forms and the high-precision ODE solution the cases compare with
- :mod:`.tolerances` -- the default bounds and a backend's declared overrides
- :mod:`.target`, ``conftest.py`` -- the ``backend`` fixture and the skip logic
- ``test_*.py`` -- the cases
"""
