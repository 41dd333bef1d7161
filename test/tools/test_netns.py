"""Hosts in network namespaces: made on a bridge, cut and restored, always removed."""

from __future__ import annotations

import subprocess

import pytest

from phd_swarm.tools import netns
from phd_swarm.tools.netns import HostNetwork, namespaces

#: A UDP echo: the receiver prints what it got and from where.
RECEIVE = ("import socket, sys; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
           "s.bind((sys.argv[1], 9999)); s.settimeout(float(sys.argv[2])); "
           "print(s.recvfrom(64)[0].decode(), flush=True)")
SEND = ("import socket, sys; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
        "s.sendto(b'hello', (sys.argv[1], 9999))")


def _send_and_receive(net: HostNetwork, to: str, sender: str, timeout: float = 2.0) -> str:
    import sys
    import time

    receiver = subprocess.Popen(net[to].command([sys.executable, "-c", RECEIVE,
                                                 net[to].address, str(timeout)]),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(0.3)
        subprocess.run(net[sender].command([sys.executable, "-c", SEND, net[to].address]),
                       check=True, timeout=10)
        out, _ = receiver.communicate(timeout=timeout + 5)
        return out.strip()
    finally:
        receiver.kill()
        receiver.wait()


def test_hosts_talk_over_their_bridge_a_cut_host_does_not_and_all_is_removed():
    with HostNetwork(["base", "field"]) as net:
        made = {net.switch, net["base"].namespace, net["field"].namespace}
        assert made <= set(namespaces())
        assert net["base"].address != net["field"].address
        shown = subprocess.run(net["field"].command(["ip", "-o", "-4", "addr"]),
                               capture_output=True, text=True, check=True).stdout
        # The host sees its loopback and its own interface, nothing of the machine's.
        assert {line.split()[1] for line in shown.splitlines()} == {"lo", netns.HOST_DEVICE}
        assert _send_and_receive(net, "base", "field") == "hello"
        net.cut("field")
        assert _send_and_receive(net, "base", "field", timeout=1.0) == ""
        net.restore("field")
        assert _send_and_receive(net, "base", "field") == "hello"
    assert not made & set(namespaces())


def test_the_namespaces_and_their_processes_are_removed_when_the_user_fails():
    with pytest.raises(RuntimeError, match="the test failed"):  # noqa: PT012
        with HostNetwork(["a"]) as net:
            made = {net.switch, net["a"].namespace}
            sleeper = subprocess.Popen(net["a"].command(["sleep", "600"]))
            raise RuntimeError("the test failed")
    assert sleeper.wait(timeout=10) != 0  # killed
    assert not made & set(namespaces())


def test_without_root_it_fails_naming_why(monkeypatch):
    monkeypatch.setattr(netns.os, "geteuid", lambda: 1000)
    with pytest.raises(RuntimeError, match="need root"):
        HostNetwork(["a"])
