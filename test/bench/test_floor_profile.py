"""The floor benchmark's shared-memory profile (``--dds shm``).

The repository's UDP profile plus Fast DDS's SHM transport for the samples, discovery still
on UDP, 127.0.0.1 only.
"""

from __future__ import annotations

import importlib.util
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from phd_swarm.tools.dds import DDS_PROFILE

BENCH = Path(__file__).resolve().parents[2] / "bench"
NS = {"f": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def _floor():
    """``bench/floor.py`` by its path (bench is no package), registered for its dataclasses."""
    if "bench_floor" in sys.modules:
        return sys.modules["bench_floor"]
    sys.path.insert(0, str(BENCH))   # floor.py imports its sibling results_io
    try:
        spec = importlib.util.spec_from_file_location("bench_floor", BENCH / "floor.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules["bench_floor"] = module
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(BENCH))
    return module


def test_the_shm_profile_adds_shared_memory_and_keeps_discovery_on_loopback_udp():
    root = ET.fromstring(_floor().shm_profile(DDS_PROFILE.read_text()))
    kinds = {d.findtext("f:transport_id", namespaces=NS): d.findtext("f:type", namespaces=NS)
             for d in root.iterfind(".//f:transport_descriptor", NS)}
    assert kinds == {"phd_swarm_loopback_udp": "UDPv4", "phd_swarm_shm": "SHM"}
    rtps = root.find(".//f:participant/f:rtps", NS)
    used = [t.text for t in rtps.iterfind("f:userTransports/f:transport_id", NS)]
    assert used == ["phd_swarm_shm", "phd_swarm_loopback_udp"]
    # No UDP default locator: Fast DDS announces one per transport, shared memory first.
    assert rtps.find("f:defaultUnicastLocatorList", NS) is None
    assert rtps.findtext("f:builtin/f:mutation_tries", namespaces=NS) == "300"
    addresses = {a.text for a in root.iterfind(".//f:address", NS)}
    assert addresses == {"127.0.0.1"}


def test_a_profile_laid_out_otherwise_is_refused():
    with pytest.raises(RuntimeError, match="not laid out as shm_profile expects"):
        _floor().shm_profile("<dds/>")
