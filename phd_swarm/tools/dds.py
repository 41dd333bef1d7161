"""DDS on loopback for the scripts' processes: Jazzy's LOCALHOST range or the repo's profile.

Kept free of heavy imports (no numpy, no rclpy), so a launcher that forks many processes
(``bench/discovery.py``) stays small.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

#: The Fast DDS profile of ``run_swarm.sh --dds profile``: UDP on 127.0.0.1 only, 160
#: participant ports probed, no shared memory (docs/deployment.md).
DDS_PROFILE = Path(__file__).resolve().parents[2] / "config" / "dds" / "loopback_udp.xml"


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
