"""Fixtures of the save/load tests: the network that uses every IR type, and that network saved."""

from __future__ import annotations

from pathlib import Path

import pytest
from network_files import full_network

import neurovpr as nv


@pytest.fixture(scope="module")
def network() -> nv.Network:
    return full_network()


@pytest.fixture
def saved(tmp_path: Path, network: nv.Network) -> Path:
    path = tmp_path / "net.h5"
    nv.save(network, path)
    return path
