"""A team over several hosts: which process runs where, and each host's DDS.

``scripts/run_swarm.sh CONFIG --hosts LAYOUT`` reads a layout file (YAML)::

    discovery: peers             # peers (simple discovery, unicast to every host) or server
    observers: base              # the host of the world, the monitor and the recorder
    hosts:
      base:   {address: 192.168.1.10}
      field1: {address: 192.168.1.11, robots: 0-9, run: [ssh, -T, field1]}
      field2: {address: 192.168.1.12, robots: "10-14,17"}

- ``address``: the host's own IPv4 address on the network the team shares. Every DDS
  socket of a process on the host is bound to it (never 0.0.0.0), and the other hosts
  reach it there.
- ``robots``: the robot ids the host runs (``0-9``, ``"0,2,5-7"`` or a list). Either every
  host but the observers' names its robots, and together they are the team exactly once;
  or none does, and the team is spread over the other hosts in blocks (over all hosts if
  the observers' host is the only one).
- ``run``: the words put before a command to run it on the host (default: none, this
  machine): ``[ip, netns, exec, NS]`` for a network namespace (the tests), ``[ssh, -T,
  HOST]`` for a machine with the same checkout at the same path (not tested here).
- ``discovery``: ``peers`` gives every participant the hosts' addresses as initial peers
  (Fast DDS simple discovery by unicast, no multicast); ``server`` runs phd_swarm's
  discovery server on the observers' host, on ``server_port`` (default 11811), and makes
  every process its client.

:func:`host_profile` is the Fast DDS profile of one host: the repository's loopback profile
(``config/dds/loopback_udp.xml``) with the host's address instead of 127.0.0.1.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from phd_swarm.nodes.team import parse_ids
from phd_swarm.tools.dds import udp_transport

#: Discovery across hosts: simple discovery with the hosts as initial peers, or a server.
DISCOVERY = ("peers", "server")

#: The discovery server's UDP port when the layout names none (Fast DDS's default).
DEFAULT_SERVER_PORT = 11811


def parse_robot_ids(value: Any, where: str) -> tuple[int, ...]:
    """Robot ids from ``3``, ``"0-9"``, ``"0,2,5-7"`` or ``[0, 1, 2]`` (errors name ``where``).

    The team process's ``--ids`` rule (:func:`phd_swarm.nodes.team.parse_ids`); an empty
    list is no robots.
    """
    if isinstance(value, bool) or not isinstance(value, int | str | list):
        raise ValueError(f"{where}: robot ids (0-9, \"0,2,5-7\" or a list), got {value!r}")
    if value == []:
        return ()
    text = ",".join(map(str, value)) if isinstance(value, list) else str(value)
    try:
        return tuple(parse_ids(text))
    except ValueError as exc:
        raise ValueError(f"{where}: {str(exc).removeprefix('--ids: ')}") from None


@dataclass(frozen=True)
class HostSpec:
    """One host of a layout: its address, the prefix that runs a command there, its robots."""

    name: str
    address: str
    run: tuple[str, ...] = ()
    robots: tuple[int, ...] | None = None


@dataclass(frozen=True)
class HostLayout:
    """Where a run's processes go (module docstring); :func:`load_layout` reads one."""

    hosts: tuple[HostSpec, ...]
    observers: str
    discovery: str = "peers"
    server_port: int = DEFAULT_SERVER_PORT
    source: str = "<layout>"

    def __post_init__(self) -> None:
        names = [h.name for h in self.hosts]
        if not names:
            raise ValueError(f"{self.source}: hosts: at least one host")
        if len(set(names)) != len(names):
            raise ValueError(f"{self.source}: hosts: names must be distinct, got {names}")
        addresses = [h.address for h in self.hosts]
        if len(set(addresses)) != len(addresses):
            raise ValueError(f"{self.source}: hosts: addresses must be distinct, got "
                             f"{addresses}")
        if self.observers not in names:
            raise ValueError(f"{self.source}: observers: {self.observers!r} is not a host "
                             f"(hosts: {', '.join(names)})")
        if self.discovery not in DISCOVERY:
            raise ValueError(f"{self.source}: discovery: one of {', '.join(DISCOVERY)}, got "
                             f"{self.discovery!r}")
        if not 0 < self.server_port < 65536:
            raise ValueError(f"{self.source}: server_port: a UDP port, got {self.server_port}")
        named = [h.name for h in self.hosts if h.robots is not None]
        unnamed = [h.name for h in self.hosts
                   if h.robots is None and h.name != self.observers]
        if named and unnamed:
            raise ValueError(f"{self.source}: hosts {', '.join(named)} name their robots and "
                             f"{', '.join(unnamed)} do not: name them on every robot host, "
                             "or on none (then the team is spread over them)")

    def host(self, name: str) -> HostSpec:
        """The host called ``name`` (ValueError naming the layout's hosts)."""
        for h in self.hosts:
            if h.name == name:
                return h
        raise ValueError(f"{self.source}: no host {name!r} (hosts: "
                         f"{', '.join(h.name for h in self.hosts)})")

    @property
    def addresses(self) -> tuple[str, ...]:
        """Every host's address, in the layout's order."""
        return tuple(h.address for h in self.hosts)

    def robot_hosts(self, robots: int) -> dict[str, tuple[int, ...]]:
        """Host name -> the robot ids it runs, for a team of ``robots``.

        ValueError if the layout does not place each of ``0..robots-1`` exactly once.
        """
        named = {h.name: h.robots for h in self.hosts if h.robots is not None}
        if named:
            placed = sorted(i for ids in named.values() for i in ids)
            if placed != list(range(robots)):
                missing = sorted(set(range(robots)) - set(placed))
                extra = sorted(set(placed) - set(range(robots)))
                raise ValueError(f"{self.source}: the hosts' robots must be the team 0-"
                                 f"{robots - 1} exactly once: missing {missing or 'none'}, "
                                 f"beyond the team {extra or 'none'}")
            return {name: ids for name, ids in named.items() if ids}
        spread = [h.name for h in self.hosts if h.name != self.observers] or [self.observers]
        out: dict[str, tuple[int, ...]] = {}
        first = 0
        for k, name in enumerate(spread):
            count = robots // len(spread) + (1 if k < robots % len(spread) else 0)
            if count:
                out[name] = tuple(range(first, first + count))
            first += count
        return out

    def server_address(self) -> str:
        """``ADDRESS:PORT`` of the discovery server (on the observers' host)."""
        return f"{self.host(self.observers).address}:{self.server_port}"

    def profile(self, name: str) -> str:
        """The Fast DDS profile of host ``name`` (:func:`host_profile`)."""
        return host_profile(self.host(name).address, self.addresses)


def _address(value: Any, where: str) -> str:
    try:
        address = ipaddress.IPv4Address(str(value))
    except ValueError:
        raise ValueError(f"{where}: an IPv4 address, got {value!r}") from None
    if address.is_unspecified or address.is_multicast:
        raise ValueError(f"{where}: the host's own address, not {address}")
    return str(address)


def layout_from_mapping(data: Mapping[str, Any], source: str = "<layout>") -> HostLayout:
    """A :class:`HostLayout` from a parsed layout file (ValueError naming ``source``)."""
    if not isinstance(data, Mapping):
        raise ValueError(f"{source}: a mapping with hosts and observers")
    unknown = set(data) - {"hosts", "observers", "discovery", "server_port"}
    if unknown:
        raise ValueError(f"{source}: unknown keys {sorted(unknown)} (known: hosts, observers, "
                         "discovery, server_port)")
    raw = data.get("hosts")
    if not isinstance(raw, Mapping) or not raw:
        raise ValueError(f"{source}: hosts: a mapping of host name -> {{address, robots, run}}")
    hosts = []
    for name, spec in raw.items():
        where = f"{source}: hosts.{name}"
        if not isinstance(spec, Mapping) or "address" not in spec:
            raise ValueError(f"{where}: a mapping with an address")
        unknown = set(spec) - {"address", "robots", "run"}
        if unknown:
            raise ValueError(f"{where}: unknown keys {sorted(unknown)} (known: address, "
                             "robots, run)")
        run = spec.get("run", ())
        if isinstance(run, str) or not all(isinstance(w, str) for w in run):
            raise ValueError(f"{where}.run: a list of words, e.g. [ssh, -T, {name}]")
        robots = spec.get("robots")
        hosts.append(HostSpec(str(name), _address(spec["address"], f"{where}.address"),
                              tuple(run), None if robots is None
                              else parse_robot_ids(robots, f"{where}.robots")))
    if "observers" not in data:
        raise ValueError(f"{source}: observers: the host of the world, monitor and recorder")
    port = data.get("server_port", DEFAULT_SERVER_PORT)
    if isinstance(port, bool) or not isinstance(port, int):
        raise ValueError(f"{source}: server_port: a UDP port, got {port!r}")
    return HostLayout(tuple(hosts), str(data["observers"]),
                      str(data.get("discovery", "peers")), port, source)


def load_layout(path: str | Path) -> HostLayout:
    """The layout file ``path`` (ValueError naming the file and the problem)."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise ValueError(f"hosts layout {path}: {exc.strerror or exc}") from None
    except yaml.YAMLError as exc:
        raise ValueError(f"hosts layout {path}: not YAML: {exc}") from None
    return layout_from_mapping(data, str(path))


def host_profile(address: str, peers: Sequence[str]) -> str:
    """The Fast DDS profile of a host at ``address`` whose team is on ``peers``.

    The repository's loopback profile (``config/dds/loopback_udp.xml``: one UDPv4 transport,
    no shared memory, 160 participant ports probed, 300 port mutation tries, 4 MB buffers)
    with the host's address instead of 127.0.0.1: every socket is bound to ``address``
    (``interfaceWhiteList``), and discovery is by unicast to every host of ``peers``. No
    shared memory also means two hosts on one machine (network namespaces) talk only over
    their network, as separate machines would.
    """
    peer_xml = "\n".join(f"          <locator><udpv4><address>{p}</address></udpv4></locator>"
                         for p in peers)
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<!-- Written by phd_swarm (phd_swarm/tools/hosts.py): the host at {address}. -->
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
{udp_transport("phd_swarm_host_udp", address, peers_range=160)}
    <participant profile_name="phd_swarm_host" is_default_profile="true">
      <rtps>
        <useBuiltinTransports>false</useBuiltinTransports>
        <userTransports><transport_id>phd_swarm_host_udp</transport_id></userTransports>
        <builtin>
          <mutation_tries>300</mutation_tries>
          <metatrafficUnicastLocatorList>
            <locator><udpv4><address>{address}</address></udpv4></locator>
          </metatrafficUnicastLocatorList>
          <initialPeersList>
{peer_xml}
          </initialPeersList>
        </builtin>
        <defaultUnicastLocatorList>
          <locator><udpv4><address>{address}</address></udpv4></locator>
        </defaultUnicastLocatorList>
      </rtps>
    </participant>
  </profiles>
</dds>
"""
