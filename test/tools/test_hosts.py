"""Host layouts (run_swarm --hosts): parsing, placing the team, each host's DDS profile."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from phd_swarm.tools import launch_plan as LP
from phd_swarm.tools.hosts import host_profile, layout_from_mapping, load_layout

NS = {"d": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}

THREE = {"observers": "base",
         "hosts": {"base": {"address": "10.1.0.1"},
                   "field1": {"address": "10.1.0.2", "run": ["ip", "netns", "exec", "f1"]},
                   "field2": {"address": "10.1.0.3"}}}


def test_the_team_is_spread_over_the_robot_hosts_in_blocks():
    layout = layout_from_mapping(THREE)
    assert layout.discovery == "peers" and layout.addresses == ("10.1.0.1", "10.1.0.2",
                                                                 "10.1.0.3")
    assert layout.robot_hosts(5) == {"field1": (0, 1, 2), "field2": (3, 4)}
    alone = layout_from_mapping({"observers": "a", "hosts": {"a": {"address": "10.1.0.1"}}})
    assert alone.robot_hosts(3) == {"a": (0, 1, 2)}


def test_named_robots_must_be_the_team_exactly_once():
    data = {"observers": "base", "hosts": {"base": {"address": "10.1.0.1", "robots": []},
                                           "f": {"address": "10.1.0.2", "robots": "0-2,5"},
                                           "g": {"address": "10.1.0.3", "robots": [3, 4]}}}
    assert layout_from_mapping(data).robot_hosts(6) == {"f": (0, 1, 2, 5), "g": (3, 4)}
    with pytest.raises(ValueError, match=r"missing \[5\], beyond the team none"):
        layout_from_mapping({**data, "hosts": {**data["hosts"], "f": {
            "address": "10.1.0.2", "robots": "0-2"}}}).robot_hosts(6)
    with pytest.raises(ValueError, match=r"beyond the team \[5\]"):
        layout_from_mapping(data).robot_hosts(5)


@pytest.mark.parametrize(("change", "message"), [
    ({"observers": "nowhere"}, "observers: 'nowhere' is not a host"),
    ({"discovery": "multicast"}, "discovery: one of peers, server"),
    ({"hosts": {"a": {"address": "0.0.0.0"}}}, r"hosts.a.address: the host's own address"),
    ({"hosts": {"a": {"address": "somewhere"}}}, "hosts.a.address: an IPv4 address"),
    ({"hosts": {"base": {"address": "10.1.0.1"}, "b": {"address": "10.1.0.1"}}},
     "addresses must be distinct"),
    ({"hosts": {"base": {"address": "10.1.0.1", "run": "ssh b"}}}, "run: a list of words"),
    ({"hosts": {"base": {"address": "10.1.0.1", "port": 3}}}, r"unknown keys \['port'\]"),
    ({"hosts": {"base": {"address": "10.1.0.1"}, "f": {"address": "10.1.0.2", "robots": 1},
                "g": {"address": "10.1.0.3"}}}, "f name their robots and g do not"),
    ({"server_port": 70000}, "server_port: a UDP port"),
])
def test_a_bad_layout_names_its_file_and_the_problem(tmp_path, change, message):
    import yaml

    path = tmp_path / "hosts.yaml"
    path.write_text(yaml.safe_dump({**THREE, **change}))
    with pytest.raises(ValueError, match=message) as info:
        load_layout(path)
    assert str(path) in str(info.value)


def test_a_missing_layout_file_is_named(tmp_path):
    with pytest.raises(ValueError, match="hosts layout .*nope.yaml"):
        load_layout(tmp_path / "nope.yaml")


def test_a_hosts_profile_binds_its_address_and_discovers_by_unicast_to_every_host():
    root = ET.fromstring(host_profile("10.1.0.2", ("10.1.0.1", "10.1.0.2", "10.1.0.3")))
    transport = root.find(".//d:transport_descriptor", NS)
    assert transport.find("d:type", NS).text == "UDPv4"
    assert [a.text for a in transport.findall("d:interfaceWhiteList/d:address", NS)] == [
        "10.1.0.2"]
    rtps = root.find(".//d:participant/d:rtps", NS)
    assert rtps.find("d:useBuiltinTransports", NS).text == "false"  # no shared memory
    peers = rtps.findall("d:builtin/d:initialPeersList/d:locator/d:udpv4/d:address", NS)
    assert [p.text for p in peers] == ["10.1.0.1", "10.1.0.2", "10.1.0.3"]
    for where in ("d:builtin/d:metatrafficUnicastLocatorList", "d:defaultUnicastLocatorList"):
        assert rtps.find(f"{where}/d:locator/d:udpv4/d:address", NS).text == "10.1.0.2"


def test_the_plan_places_each_process_on_its_host_with_its_hosts_profile(tmp_path):
    layout = layout_from_mapping({**THREE, "discovery": "server"})
    rc = LP.resolve_config(LP.find_config("config/dames_static.yaml"), robots=5)
    plan = LP.swarm_plan(rc, tmp_path, LP.SwarmOptions(robots_per_process=2, hosts=layout),
                         base_env={"FASTRTPS_DEFAULT_PROFILES_FILE": "/elsewhere.xml"})
    assert plan.use_server and plan.hosts is layout
    assert plan.env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SYSTEM_DEFAULT"
    assert "FASTRTPS_DEFAULT_PROFILES_FILE" not in plan.env
    where = {p.name: p.host for p in plan.processes}
    assert where == {"recorder": "base", "monitor": "base", "world": "base",
                     "robots_0-1": "field1", "robots_2-2": "field1", "robots_3-4": "field2"}
    for p in plan.processes:
        assert p.prefix == layout.host(p.host).run
        assert dict(p.env)["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(
            tmp_path / "dds" / f"{p.host}.xml")
    assert plan.files == {tmp_path / "dds" / f"{h}.xml": layout.profile(h)
                          for h in ("base", "field1", "field2")}
    # The nodes' parameters are those of the one-host plan: placing them changes nothing.
    alone = LP.swarm_plan(rc, tmp_path, LP.SwarmOptions(robots_per_process=2))
    assert plan.rc.nodes == alone.rc.nodes
    assert plan.world.argv() == alone.world.argv()
