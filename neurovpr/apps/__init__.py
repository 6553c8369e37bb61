"""Applications built on the core: the model plugin interface and cross-backend comparison.

- :mod:`.modelapi` -- how models are found (entry points) and what they implement
- :mod:`.compare` -- one trained model run on several backends, off- vs on-chip
- :mod:`.compare_plots` -- the plots of a comparison
"""
