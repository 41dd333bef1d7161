"""The view server listens on 127.0.0.1 only, with analytics off, and is stopped by PID.

Marked ``full``: it needs rerun-sdk (``scripts/setup.sh --with-view``, which
``scripts/test.sh --full`` runs).
"""

from __future__ import annotations

import json
import os
import re
import urllib.request
from pathlib import Path

import pytest

pytestmark = pytest.mark.full


def listening(pid: int) -> list[tuple[str, int]]:
    """(address, port) of every TCP socket process ``pid`` listens on (IPv4 and IPv6)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        target = os.readlink(fd) if fd.is_symlink() else ""
        if m := re.fullmatch(r"socket:\[(\d+)\]", target):
            inodes.add(m.group(1))
    out = []
    for table in ("tcp", "tcp6"):
        for line in Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]:
            fields = line.split()
            local, state, inode = fields[1], fields[3], fields[9]
            if state != "0A" or inode not in inodes:        # 0A: LISTEN
                continue
            address, port = local.split(":")
            raw = bytes.fromhex(address)
            if table == "tcp":
                host = ".".join(str(b) for b in raw[::-1])
            else:                                           # 4 little-endian words
                words = [raw[i:i + 4][::-1] for i in range(0, 16, 4)]
                host = b"".join(words).hex()
            out.append((host, int(port, 16)))
    return out


def test_the_view_server_listens_on_loopback_only_and_stops():
    from phd_swarm.tools.view_server import ViewServer

    with ViewServer() as server:
        sockets = listening(server.pid)
        assert len(sockets) == 2, sockets                   # the web viewer and the proxy
        assert {host for host, _ in sockets} == {"127.0.0.1"}, sockets
        ports = {port for _, port in sockets}
        web = int(re.search(r"127\.0\.0\.1:(\d+)/", server.url).group(1))
        grpc = int(re.search(r":(\d+)/proxy$", server.grpc_url).group(1))
        assert ports == {web, grpc}
        page = urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=10).read()
        assert b"Rerun" in page
        # Its analytics are off, in a configuration of its own.
        config = Path(f"/proc/{server.pid}/environ").read_bytes().split(b"\0")
        home = next(v for v in config if v.startswith(b"XDG_CONFIG_HOME=")).split(b"=", 1)[1]
        analytics = json.loads((Path(home.decode()) / "rerun" / "analytics.json").read_text())
        assert analytics["analytics_enabled"] is False
        pid = server.pid
    assert not Path(f"/proc/{pid}").exists() or \
        Path(f"/proc/{pid}/status").read_text().find("State:\tZ") >= 0


def test_the_commands_serve_a_view_and_shoot_it(tmp_path, children):
    """The view server's and the screenshot's commands, as users run them.

    ``python -m phd_swarm.tools.view_server`` prints the URL and serves until Ctrl-C;
    ``python -m phd_swarm.tools.browser_shot URL OUT`` writes a screenshot of it that is
    not one colour.
    """
    import sys

    import numpy as np

    from phd_swarm.tools.browser_shot import png_pixels

    server = children.start([sys.executable, "-m", "phd_swarm.tools.view_server"])
    line = server.stdout.readline()
    url = re.fullmatch(r"view: (http://127\.0\.0\.1:\d+/\?url=\S+)\n", line)
    assert url, line
    assert "rerun_url:=rerun+http://127.0.0.1:" in server.stdout.readline()
    out = tmp_path / "shot.png"
    shot = children.start([sys.executable, "-m", "phd_swarm.tools.browser_shot",
                           url.group(1), str(out), "--size", "800x600", "--timeout", "120"])
    stdout, stderr = shot.communicate(timeout=180)
    assert shot.returncode == 0, stderr
    pixels = png_pixels(out.read_bytes())
    assert pixels.shape == (600, 800, 3)
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 1
    children.stop(server, grace=10.0)
    assert server.returncode == 0
