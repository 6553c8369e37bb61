"""SynSense's samna-free modules import through neurovpr's scoped package-init skip, and failures are reported."""

from __future__ import annotations

import importlib.util
import sys

import pytest

from neurovpr.backendkit.vendor_imports import import_without_parent_init
from neurovpr.errors import BackendUnavailableError


def test_missing_vendor_package_is_reported_with_the_hint():
    with pytest.raises(BackendUnavailableError, match=r"Package json\.nopackage is not installed; install it"):
        import_without_parent_init("json.nopackage", ("x",), hint="install it.")


def test_failing_module_is_named():
    with pytest.raises(BackendUnavailableError, match=r"Cannot import xml\.dom\.no_such_module .*ModuleNotFoundError"):
        import_without_parent_init("xml.dom", ("no_such_module",), hint="x")


@pytest.mark.skipif(importlib.util.find_spec("rockpool") is None, reason="rockpool not installed (synsense extra)")
def test_rockpool_xylo_audio_2_imports_without_samna():
    from neurovpr.backends.xylo.compat import import_xylo

    x = import_xylo()
    assert hasattr(x.mapper, "mapper") and hasattr(x.sim, "XyloSim")
    assert importlib.util.find_spec("samna") is None
    # the Xylo package's own __init__ (which imports samna) was skipped: a bare package stands in
    assert getattr(sys.modules["rockpool.devices.xylo"], "__file__", None) is None


@pytest.mark.skipif(importlib.util.find_spec("sinabs") is None, reason="sinabs not installed (install_synsense.sh)")
def test_sinabs_dynapcnn_mapping_imports_without_samna():
    from neurovpr.backends.speck.compat import import_dynapcnn

    d = import_dynapcnn()
    assert hasattr(d.mapping, "get_valid_mapping") and hasattr(d.layer, "DynapcnnLayer")
    assert hasattr(d.layers, "IAFSqueeze")
