"""The backend conformance suite.

Every test runs once per backend that the ``neurovpr.backends`` entry point
declares and compares what the backend simulates with an analytic answer derived
from ``docs/semantics.md``. A backend that cannot run a case lists the case id
(see :mod:`.cases`) with the reason in ``Capabilities.unsupported``; the test then
skips with that reason. Where a simulator's numerics legitimately differ from the
exact-integration reference, :mod:`.tolerances` records the looser bound and why.

Set ``NEUROVPR_BACKENDS=name1,name2`` to run only some backends.
"""
