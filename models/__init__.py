"""The papers' models and the non-spiking baselines, installed as ``neurovpr.models.<name>``."""
