"""Hosts on one machine: Linux network namespaces on a bridge, made and removed by us.

:class:`HostNetwork` makes one network namespace per named host and one more that holds the
"switch": a bridge with one veth port per host. Each host sees one interface, ``eth0``,
with an address on a private /24 of its own, and its loopback; it sees nothing of the
machine's own interfaces, and the machine's own network namespace is never changed (no
interface, address or route is added to it). :meth:`HostNetwork.close` kills every process
still inside the namespaces and deletes them, which removes their interfaces with them;
the tests and benchmarks that use it call it in a ``finally`` (it is a context manager).

``cut(host)`` / ``restore(host)`` set the host's port on the switch down and up: the cable
pulled at the switch, the host's own interface and address kept.

Needs root (``ip netns add``) and iproute2; :func:`require_hosts` says which is missing.
"""

from __future__ import annotations

import itertools
import os
import shutil
import signal
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass

#: The interface a host sees, and the bridge in the switch namespace.
HOST_DEVICE = "eth0"
BRIDGE = "br0"

_serial = itertools.count()


def require_hosts() -> None:
    """Raise RuntimeError naming why network namespaces cannot be made here (not root, no ip)."""
    if os.geteuid() != 0:
        raise RuntimeError("network namespaces need root (ip netns add); this process runs "
                           f"as uid {os.geteuid()}")
    if shutil.which("ip") is None:
        raise RuntimeError("network namespaces need iproute2's `ip`, which is not on PATH")


def _ip(*args: str) -> None:
    done = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if done.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {done.stderr.strip() or done.returncode}")


@dataclass(frozen=True)
class Host:
    """One host: its network namespace and its address on the bridge."""

    name: str
    namespace: str
    address: str
    #: Its port on the switch (``cut`` sets it down).
    port: str

    def command(self, argv: Sequence[str]) -> list[str]:
        """``argv`` run inside the host: ``ip netns exec NAMESPACE argv``.

        ``ip netns exec`` execs the command, so the process started is the command itself
        (its PID is the command's) with the caller's environment.
        """
        return ["ip", "netns", "exec", self.namespace, *argv]

    @property
    def prefix(self) -> tuple[str, ...]:
        """The words put before a command to run it inside the host."""
        return ("ip", "netns", "exec", self.namespace)


class HostNetwork:
    """Named hosts in network namespaces of their own, on one bridge (module docstring).

    ``HostNetwork(["base", "field1", "field2"])`` gives hosts with addresses
    ``10.<a>.<b>.1``, ``.2``, ``.3`` on a /24 chosen from the process id and a counter, so
    two networks made at once do not share a subnet. Use it as a context manager, or call
    :meth:`close` in a ``finally``.
    """

    def __init__(self, names: Sequence[str]) -> None:
        require_hosts()
        if not names or len(set(names)) != len(names) or len(names) > 250:
            raise ValueError(f"hosts: 1-250 distinct names, got {list(names)}")
        serial = next(_serial)
        tag = f"{os.getpid() % 100000}{serial}"
        self.prefix = f"swarm{tag}-"
        third = (os.getpid() + serial) % 250 + 1
        self.subnet = f"10.213.{third}.0/24"
        self.switch = f"{self.prefix}switch"
        self.hosts: dict[str, Host] = {}
        self._made: list[str] = []
        try:
            self._make(list(names), third)
        except BaseException:
            self.close()
            raise

    def _make(self, names: list[str], third: int) -> None:
        _ip("netns", "add", self.switch)
        self._made.append(self.switch)
        _ip("-n", self.switch, "link", "add", BRIDGE, "type", "bridge")
        _ip("-n", self.switch, "link", "set", BRIDGE, "up")
        for i, name in enumerate(names):
            ns = f"{self.prefix}{name}"[:60]
            port = f"port{i}"
            _ip("netns", "add", ns)
            self._made.append(ns)
            _ip("-n", self.switch, "link", "add", port, "type", "veth", "peer", "name",
                HOST_DEVICE, "netns", ns)
            _ip("-n", self.switch, "link", "set", port, "master", BRIDGE)
            _ip("-n", self.switch, "link", "set", port, "up")
            address = f"10.213.{third}.{i + 1}"
            _ip("-n", ns, "addr", "add", f"{address}/24", "dev", HOST_DEVICE)
            _ip("-n", ns, "link", "set", HOST_DEVICE, "up")
            _ip("-n", ns, "link", "set", "lo", "up")
            self.hosts[name] = Host(name, ns, address, port)

    def __enter__(self) -> HostNetwork:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __getitem__(self, name: str) -> Host:
        return self.hosts[name]

    def cut(self, name: str) -> None:
        """Pull host ``name``'s cable: its port on the switch goes down."""
        _ip("-n", self.switch, "link", "set", self.hosts[name].port, "down")

    def restore(self, name: str) -> None:
        """Plug host ``name``'s cable back in: its port on the switch comes up."""
        _ip("-n", self.switch, "link", "set", self.hosts[name].port, "up")

    def pids(self) -> list[int]:
        """Processes still running inside any of the namespaces."""
        out: list[int] = []
        for ns in self._made:
            done = subprocess.run(["ip", "netns", "pids", ns], capture_output=True,
                                  text=True, timeout=30)
            out += [int(p) for p in done.stdout.split()]
        return out

    def close(self) -> None:
        """Kill every process inside the namespaces, then delete them (and their links)."""
        for _ in range(3):
            pids = self.pids()
            if not pids:
                break
            for pid in pids:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            time.sleep(0.2)
        for ns in reversed(self._made):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=30,
                           check=False)
        self._made.clear()


def namespaces() -> list[str]:
    """The network namespaces that exist now (``ip netns list``), by name."""
    done = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True,
                          timeout=30, check=False)
    return [line.split()[0] for line in done.stdout.splitlines() if line.strip()]
