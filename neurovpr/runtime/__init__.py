"""Running a network: backends, the registry that finds them, ``compile`` and the ``Simulation`` interface.

- :mod:`.backend` -- what a backend is (its capability declaration and ``compile``)
- :mod:`.registry` -- backends found through the ``neurovpr.backends`` entry point
- :mod:`.compiler` -- ``neurovpr.compile``
- :mod:`.simulation` -- the ``Simulation`` interface every backend implements
- :mod:`.batch` -- ``Simulation.run_batch``: many independent items through one network
"""
