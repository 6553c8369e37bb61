"""Datasets, encoders and event streams."""
