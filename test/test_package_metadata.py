"""Package metadata: one version everywhere, the licence, the citation file; lint."""

from __future__ import annotations

import hashlib
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml
from catkin_pkg.changelog import get_changelog_from_path

import phd_swarm

ROOT = Path(__file__).resolve().parents[1]

#: sha256 of the Apache License 2.0 as published (apache.org/licenses/LICENSE-2.0.txt).
APACHE_2_SHA256 = "cfc7749b96f63bd31c3c42b5c471bf756814053e847c10f3eb003417bc523d30"


def _xml_version(path: Path) -> str:
    return ET.parse(path).getroot().findtext("version")


def _setup_py(field: str) -> str:
    return re.search(rf'{field}="([^"]+)"', (ROOT / "setup.py").read_text()).group(1)


def _citation() -> dict:
    return yaml.safe_load((ROOT / "CITATION.cff").read_text())


def test_versions_agree():
    setup_version = _setup_py("version")
    assert setup_version == _xml_version(ROOT / "package.xml") == phd_swarm.__version__
    assert _xml_version(ROOT / "msg_defs" / "package.xml") == setup_version


# catkin_pkg (1.1) calls docutils' deprecated Node.traverse; not ours to fix.
@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_changelog_citation_and_readme_name_the_same_version():
    version = _xml_version(ROOT / "package.xml")
    # As the ROS release tools read it (bloom uses catkin_pkg's parser); newest entry first.
    changelog = get_changelog_from_path(str(ROOT / "CHANGELOG.rst"), "phd_swarm")
    entries = list(changelog.foreach_version())
    assert entries, "CHANGELOG.rst has no version section"
    newest, date, content = entries[0]
    assert newest == version == _setup_py("version"), (newest, version)
    assert date is not None and str(content).strip()
    assert str(_citation()["version"]) == version
    assert f"Version {version}" in (ROOT / "README.md").read_text()
    msgs = get_changelog_from_path(str(ROOT / "msg_defs" / "CHANGELOG.rst"), "phd_swarm_msgs")
    newest = next(iter(msgs.foreach_version()))[0]
    assert newest == _xml_version(ROOT / "msg_defs" / "package.xml") == version


def test_licence_is_the_apache_2_text_everywhere():
    text = (ROOT / "LICENSE").read_bytes()
    assert hashlib.sha256(text).hexdigest() == APACHE_2_SHA256, "LICENSE is not Apache-2.0"
    assert b"Apache License" in text and b"Version 2.0, January 2004" in text
    package = ET.parse(ROOT / "package.xml").getroot()
    assert [e.text for e in package.findall("license")] == ["Apache-2.0"]
    assert _setup_py("license") == "Apache-2.0" == _citation()["license"]


def test_citation_names_the_software_and_the_five_papers():
    cff = _citation()
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["title"] == "phd_swarm" and cff["authors"]
    references = cff["references"]
    assert len(references) == 5
    for ref in references:
        assert ref["title"] and ref["authors"] and isinstance(ref["year"], int), ref
    first_authors = sorted(ref["authors"][0]["family-names"] for ref in references)
    assert first_authors == ["Chen", "Dames", "Papaioannou", "Shirsat", "Sung"]


def test_ruff_finds_nothing():
    ruff = shutil.which("ruff")
    assert ruff, "ruff is in requirements.lock; run scripts/setup.sh"
    paths = [d for d in ("phd_swarm", "test", "bench", "examples") if (ROOT / d).is_dir()]
    result = subprocess.run([ruff, "check", "--no-cache", *paths],
                            cwd=ROOT, capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
