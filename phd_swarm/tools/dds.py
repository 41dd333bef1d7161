"""DDS on loopback for the scripts' processes: Jazzy's LOCALHOST range or the repo's profile.

Kept free of heavy imports (no numpy, no rclpy), so a launcher that forks many processes
(``bench/discovery.py``) stays small.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path


def _profile_path() -> Path:
    """The profile in the source tree, else the installed copy (``share/phd_swarm/config``).

    A ``colcon build`` without ``--symlink-install`` installs the package without the
    source tree beside it; setup.py installs ``config/dds/*.xml`` into the share directory.
    """
    relative = Path("config") / "dds" / "loopback_udp.xml"
    source = Path(__file__).resolve().parents[2] / relative
    if source.is_file():
        return source
    try:
        from ament_index_python.packages import (
            PackageNotFoundError,
            get_package_share_directory,
        )
    except ImportError:
        return source
    try:
        return Path(get_package_share_directory("phd_swarm")) / relative
    except PackageNotFoundError:
        return source


#: The Fast DDS profile of ``run_swarm.sh --dds profile``: UDP on 127.0.0.1 only, 160
#: participant ports probed, no shared memory (docs/deployment.md).
DDS_PROFILE = _profile_path()


def dds_env(base: Mapping[str, str], profile: bool) -> dict[str, str]:
    """``base`` with DDS kept on loopback: Jazzy's LOCALHOST range, or the repository's profile.

    The profile (:data:`DDS_PROFILE`) needs ``ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT``:
    with LOCALHOST rmw_fastrtps replaces its transports by shared memory and a UDP transport
    probing 32 ports. Both name the profile file (Fast DDS 2.x reads FASTRTPS_..., 3.x
    FASTDDS_...). Raises FileNotFoundError if the profile is missing.
    """
    env = dict(base)
    if profile:
        # Fast DDS ignores a profile file it cannot read and falls back to its defaults,
        # which discover over multicast on every interface: refuse instead.
        if not DDS_PROFILE.is_file():
            raise FileNotFoundError(f"the Fast DDS profile {DDS_PROFILE} is missing; without "
                                    "it DDS would not stay on loopback")
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
        env["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(DDS_PROFILE)
        env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(DDS_PROFILE)
    else:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        for var in ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE"):
            if env.get(var) == str(DDS_PROFILE):
                del env[var]
    return env


#: GUID prefix of discovery server 0 (Fast DDS's default for server id 0, the one
#: ``ROS_DISCOVERY_SERVER=127.0.0.1:PORT`` names).
SERVER_PREFIX = "44.53.00.5f.45.50.52.4f.53.49.4d.41"

#: Variables that make a participant a client of a server, or a super client.
CLIENT_VARS = ("ROS_DISCOVERY_SERVER", "ROS_SUPER_CLIENT")


def udp_transport(transport_id: str, address: str, peers_range: int | None = None) -> str:
    """The ``<transport_descriptors>`` of a phd_swarm profile: one UDPv4 transport on ``address``.

    Bound to ``address`` only (``interfaceWhiteList``), 4 MB socket buffers, and
    ``peers_range`` participant ports probed per initial peer when given.
    """
    probe = ("" if peers_range is None
             else f"\n        <maxInitialPeersRange>{peers_range}</maxInitialPeersRange>")
    return f"""    <transport_descriptors>
      <transport_descriptor>
        <transport_id>{transport_id}</transport_id>
        <type>UDPv4</type>
        <interfaceWhiteList><address>{address}</address></interfaceWhiteList>{probe}
        <sendBufferSize>4194304</sendBufferSize>
        <receiveBufferSize>4194304</receiveBufferSize>
      </transport_descriptor>
    </transport_descriptors>"""


def server_profile(port: int, address: str = "127.0.0.1") -> str:
    """A Fast DDS profile: the default participant is discovery server 0 on address:port.

    Its UDP transport is bound to ``address`` only (127.0.0.1, as :data:`DDS_PROFILE`'s is;
    a host's own address with ``run_swarm.sh --hosts``).

    ``fast-discovery-server`` adds transports of its own that bind every interface (seen on
    this machine: 0.0.0.0 and the host's address even with ``-l 127.0.0.1`` and ``-x``), so
    phd_swarm runs its server as an rclpy process with this profile instead
    (:mod:`phd_swarm.tools.discovery_server`).
    """
    if not 0 < port < 65536:
        raise ValueError(f"discovery server port {port} is not a UDP port")
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<!-- Written by phd_swarm (phd_swarm/tools/dds.py): discovery server 0 on {address}:{port}. -->
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
{udp_transport("phd_swarm_server_udp", address)}
    <participant profile_name="phd_swarm_discovery_server" is_default_profile="true">
      <rtps>
        <prefix>{SERVER_PREFIX}</prefix>
        <useBuiltinTransports>false</useBuiltinTransports>
        <userTransports><transport_id>phd_swarm_server_udp</transport_id></userTransports>
        <builtin>
          <discovery_config><discoveryProtocol>SERVER</discoveryProtocol></discovery_config>
          <metatrafficUnicastLocatorList>
            <locator><udpv4><address>{address}</address><port>{port}</port></udpv4></locator>
          </metatrafficUnicastLocatorList>
        </builtin>
        <defaultUnicastLocatorList>
          <locator><udpv4><address>{address}</address></udpv4></locator>
        </defaultUnicastLocatorList>
      </rtps>
    </participant>
  </profiles>
</dds>
"""


def server_env(base: Mapping[str, str], profile: Path) -> dict[str, str]:
    """``base`` for the discovery server process: its own profile, and not a client."""
    env = {k: v for k, v in base.items() if k not in CLIENT_VARS}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"
    env["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(profile)
    env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(profile)
    return env


def free_udp_port() -> int:
    """A UDP port on 127.0.0.1 that nothing holds right now."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]
