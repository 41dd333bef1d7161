"""Package metadata agrees across setup.py, package.xml and the Python package; lint."""

from __future__ import annotations

import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import phd_swarm

ROOT = Path(__file__).resolve().parents[1]


def _xml_version(path: Path) -> str:
    return ET.parse(path).getroot().findtext("version")


def test_versions_agree():
    setup_version = re.search(r'version="([^"]+)"', (ROOT / "setup.py").read_text()).group(1)
    assert setup_version == _xml_version(ROOT / "package.xml") == phd_swarm.__version__
    assert _xml_version(ROOT / "msg_defs" / "package.xml") == setup_version


def test_ruff_finds_nothing():
    ruff = shutil.which("ruff")
    assert ruff, "ruff is in requirements.lock; run scripts/setup.sh"
    paths = [d for d in ("phd_swarm", "test", "bench", "examples") if (ROOT / d).is_dir()]
    result = subprocess.run([ruff, "check", "--no-cache", *paths],
                            cwd=ROOT, capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
