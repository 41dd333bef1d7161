"""The repository's Fast DDS profile keeps every socket on 127.0.0.1, and peers still talk.

``config/dds/loopback_udp.xml`` (with ``ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT``) is
the discovery for teams of more than 32 processes on one host. A UDP socket bound to
127.0.0.1 can only send from and receive on the loopback interface, so a process whose
every UDP socket is bound there sends nothing on another interface. The test reads the
processes' sockets from /proc: their inodes from /proc/PID/fd, their local addresses from
/proc/PID/net/udp and udp6.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]
PEER = Path(__file__).with_name("loopback_peer.py")
PROFILE = ROOT / "config" / "dds" / "loopback_udp.xml"


def profile_env() -> dict[str, str]:
    return {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
            "FASTRTPS_DEFAULT_PROFILES_FILE": str(PROFILE),
            "FASTDDS_DEFAULT_PROFILES_FILE": str(PROFILE)}


def _hex_to_address(text: str) -> str:
    """/proc/net/udp's ``0100007F:1CEB`` (IPv4, host byte order) or the IPv6 form."""
    addr, _ = text.split(":")
    raw = bytes.fromhex(addr)
    if len(raw) == 4:
        return ".".join(str(b) for b in raw[::-1])
    words = [raw[i:i + 4][::-1] for i in range(0, 16, 4)]
    return ":".join(w.hex() for w in words)


def udp_bindings(pid: int, ports: bool = False) -> list[str]:
    """Local addresses (``address:port`` with ``ports``) of the UDP sockets ``pid`` holds."""
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    addresses = []
    for table in ("udp", "udp6"):
        path = Path(f"/proc/{pid}/net/{table}")
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            fields = line.split()
            if fields[9] in inodes:
                address = _hex_to_address(fields[1])
                port = int(fields[1].split(":")[1], 16)
                addresses.append(f"{address}:{port}" if ports else address)
    return addresses


def test_the_address_parser_reads_both_tables():
    assert _hex_to_address("0100007F:1CEB") == "127.0.0.1"
    assert _hex_to_address("00000000:1CEB") == "0.0.0.0"
    assert _hex_to_address("00000000000000000000000001000000:1CEB").endswith("00000001")


def _bindings_while_talking(children, env) -> list[str]:
    sub = children.start([sys.executable, str(PEER), "sub"], env=env)
    pub = children.start([sys.executable, str(PEER), "pub"], env=env)
    try:
        out, err = sub.communicate(timeout=30.0)
    except subprocess.TimeoutExpired:
        children.stop(pub)
        children.stop(sub)
        pytest.fail("the subscriber received nothing within 30 s")
    assert sub.returncode == 0, err
    assert any(line.startswith("GOT 9") for line in out.splitlines()), out
    time.sleep(0.5)
    assert pub.poll() is None, "the publisher died early"
    bindings = udp_bindings(pub.pid)
    children.stop(pub)
    return bindings


def test_with_the_profile_every_socket_is_on_loopback(children):
    bindings = _bindings_while_talking(children, profile_env())
    assert bindings, "the publisher holds no UDP socket"
    assert set(bindings) == {"127.0.0.1"}, bindings


def test_jazzy_localhost_mode_binds_the_wildcard_address(children):
    """Why the profile binds explicitly.

    LOCALHOST confines where Fast DDS sends (unicast to 127.0.0.1, no multicast), but its
    sockets listen on every interface.
    """
    bindings = _bindings_while_talking(children, {"ROS_AUTOMATIC_DISCOVERY_RANGE":
                                                  "LOCALHOST"})
    assert "0.0.0.0" in bindings, bindings



def test_the_discovery_server_and_its_clients_stay_on_loopback(children, tmp_path):
    """run_swarm's discovery server (an rclpy process with a server profile) and two clients.

    The two clients are given the server as their only discovery peer, find each other
    through it and talk; every UDP socket of the server and of a client is bound to
    127.0.0.1.
    """
    from phd_swarm.tools.dds import free_udp_port, server_env, server_profile

    port = free_udp_port()
    profile = tmp_path / "server.xml"
    profile.write_text(server_profile(port))
    base = {**os.environ, **profile_env()}
    server = children.start([sys.executable, "-m", "phd_swarm.tools.discovery_server",
                             "--profile", str(profile), "--port", str(port)],
                            env=server_env(base, profile))
    deadline = time.monotonic() + 30.0
    while f"127.0.0.1:{port}" not in udp_bindings(server.pid, ports=True):
        assert server.poll() is None, server.communicate()
        assert time.monotonic() < deadline, "the server did not bind its port within 30 s"
        time.sleep(0.1)
    client = {**base, "ROS_DISCOVERY_SERVER": f"127.0.0.1:{port}"}
    bindings = _bindings_while_talking(children, client)
    assert bindings and set(bindings) == {"127.0.0.1"}, bindings
    server_bindings = udp_bindings(server.pid)
    assert set(server_bindings) == {"127.0.0.1"}, server_bindings
    children.stop(server)
    assert server.returncode == 0, server.communicate()


def _occupy_participant_ports(domain: int, participants: int) -> list[socket.socket]:
    """Bind the unicast ports of the first ``participants`` participant slots of ``domain``.

    RTPS gives participant ``p`` the ports 7400 + 250 d + 10 + 2 p (discovery) and + 11 + 2 p
    (user data); a new participant takes the first free slot.
    """
    base = 7400 + 250 * domain + 10
    held = []
    for port in range(base, base + 2 * participants):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", port))
        held.append(s)
    return held


def test_with_the_profile_peers_past_the_hundredth_participant_talk(children):
    """The 102nd participant on a host must still discover and be discovered.

    Fast DDS looks for a free participant slot at most ``mutation_tries`` times (100 by
    default); past that a participant opened no discovery socket and never found anybody
    (100 robot processes, docs/deployment.md). With the first 110 slots held, two peers on
    the profile (300 tries) still talk.
    """
    held = _occupy_participant_ports(children.domain_id, 110)
    try:
        bindings = _bindings_while_talking(children, profile_env())
    finally:
        for s in held:
            s.close()
    assert set(bindings) == {"127.0.0.1"}, bindings
