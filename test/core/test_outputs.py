"""Declared outputs and observations: what a part publishes and how observers read it."""

from __future__ import annotations

import pytest

from phd_swarm.core import registry
from phd_swarm.core.outputs import NODE_OUTPUTS, Observation, Output, output_topics, system_outputs
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.presets import PRESETS

FACE = "phd_swarm.nodes.faces.grid_phd:DENSITY"


@pytest.mark.parametrize("kwargs, match", [
    ({"topic": "a/b"}, "relative name"),
    ({"topic": "status"}, "written by every robot node"),
    ({"type": "DensityGrid"}, "pkg/msg/Type"),
    ({"face": "no_colon"}, "module:NAME"),
])
def test_an_output_refuses_what_cannot_be_a_robot_topic(kwargs, match):
    args = {"topic": "density", "type": "phd_swarm_msgs/msg/DensityGrid", "face": FACE,
            "description": "x", **kwargs}
    with pytest.raises(ValueError, match=match):
        Output(**args)


def test_step_outputs_are_the_step_qos_ones():
    assert Output("a", "p/msg/T", FACE, "x").per_step
    assert not Output("a", "p/msg/T", FACE, "x", qos="OBSERVATION").per_step


def test_each_system_declares_its_topics_in_role_order_and_a_topic_has_one_writer():
    parts = {name: make().system.parts() for name, make in PRESETS.items()}
    assert output_topics(parts["dames_static"]) == (*NODE_OUTPUTS, "density", "density_grid",
                                                    "cell")
    assert output_topics(parts["dames_static"], per_step=True) == (*NODE_OUTPUTS, "density",
                                                                   "cell")
    assert output_topics(parts["dames_static"], drop=["density", "density_grid"]) == (
        *NODE_OUTPUTS, "cell")
    assert output_topics(parts["sung_tokekar"], per_step=False) == ("markers",)
    assert output_topics(parts["shirsat_berman"], per_step=True) == (
        *NODE_OUTPUTS, "components", "reward_set")
    twice = dict(parts["dames_static"])
    twice["controller"] = registry.lookup("exchange", "voronoi_phd")
    with pytest.raises(ValueError, match="'cell' is declared by exchange 'voronoi_phd' and "
                                         "by controller 'voronoi_phd'"):
        system_outputs(twice)


def test_an_observation_reads_only_its_inputs_and_a_system_only_declared_ones():
    with pytest.raises(ValueError, match="'density' is not one of its inputs"):
        Observation(inputs=("cell",), image="density")
    with pytest.raises(ValueError, match="module:NAME"):
        Observation(inputs=("a",), view="nope")
    obs = registry.lookup("estimator", "grid_phd").observation
    assert (obs.inputs, obs.image) == (("density",), "density")
    assert registry.lookup("estimator", "sung_gmphd").observation.view.endswith(
        ":estimator_view")
    assert registry.lookup("estimator", "papaioannou_sat").observation == Observation()


def test_a_system_whose_observers_read_an_undeclared_topic_is_refused(tmp_path):
    plugin = tmp_path / "unread_probe.py"
    plugin.write_text(
        "from phd_swarm.core import registry\n"
        "from phd_swarm.core.outputs import Observation\n"
        "base = registry.lookup('estimator', 'grid_phd')\n"
        "registry.register('estimator', 'unread_probe', base.make, setup=base.setup,\n"
        "                  description='probe', provides=base.provides,\n"
        "                  requires=base.requires,\n"
        "                  observation=Observation(inputs=('nowhere',)))\n")
    try:
        with pytest.raises(ValueError, match=r"observed through \['nowhere'\], which no part"):
            SystemConfig(estimator="unread_probe", plugins=(str(plugin),))
    finally:
        registry._PARTS["estimator"].pop("unread_probe", None)
