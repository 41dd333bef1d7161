"""A node process imports only what it needs to start (start-up CPU, issue 21).

Every robot process pays its imports once; with 100 processes on 2 cores that is most of the
start-up. scipy.signal (with scipy.stats behind it) alone took ~0.5 s and is used only by the
FFT path of the grid PHD's prediction, so it is imported there.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("scipy.signal", "scipy.stats")


@pytest.mark.parametrize("module", ["phd_swarm.nodes.robot", "phd_swarm.nodes.world",
                                    "phd_swarm.nodes.recorder"])
def test_a_node_module_does_not_import_scipy_signal_or_stats(module):
    code = (f"import sys, {module}; "
            f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120).stdout.strip()
    assert out == "", f"{module} imports {out}"
