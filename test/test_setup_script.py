"""scripts/setup.sh: which edits make it rebuild the colcon packages (--build-hash)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _hash(tree: Path) -> str:
    out = subprocess.run(["bash", str(tree / "scripts" / "setup.sh"), "--build-hash"],
                         capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_editing_a_config_needs_no_rebuild_but_adding_one_or_a_message_does(tmp_path):
    tree = tmp_path / "repo"
    for name in ("msg_defs", "config", "resource", "scripts"):
        shutil.copytree(ROOT / name, tree / name)
    for name in ("package.xml", "setup.py", "setup.cfg", "requirements.lock"):
        shutil.copy(ROOT / name, tree / name)
    first = _hash(tree)
    assert len(first) == 64 and first == _hash(tree)
    # Configs are installed as symlinks: a new value is read without a rebuild.
    config = tree / "config" / "dames_static.yaml"
    config.write_text(config.read_text() + "\n# edited\n")
    (tree / "config" / "sweeps" / "mine.yaml").write_text("preset: dames_static\n")
    assert _hash(tree) == first
    # A new installed config file, or a changed message, must be built.
    (tree / "config" / "mine.yaml").write_text("/**: {}\n")
    second = _hash(tree)
    assert second != first
    msg = next((tree / "msg_defs" / "msg").glob("*.msg"))
    msg.write_text(msg.read_text() + "\n# edited\n")
    assert _hash(tree) != second
