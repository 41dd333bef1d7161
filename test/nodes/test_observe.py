"""Faces build a part's declared outputs; observers read them back as the engine sees them.

An agent of the in-memory engine after a few steps: every declared output of its system is
built by its face (the robot node's code path, :class:`~phd_swarm.nodes.face.Step`), and
the observers' :class:`~phd_swarm.nodes.observe.TeamReader` reads the messages back into
the values the engine holds (bit for bit) and the views the figures hooks take.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from phd_swarm.core.controllers.base import Decision
from phd_swarm.core.outputs import Output
from phd_swarm.engines.distributed import DistributedEngine
from phd_swarm.nodes import convert
from phd_swarm.nodes.face import Face, Step, load_face
from phd_swarm.nodes.observe import TeamReader, add_windows, read_estimates, union
from phd_swarm.nodes.topics import declared_outputs
from phd_swarm.sim.presets import PRESETS
from phd_swarm_msgs.msg import DensityGrid, TargetSet


def _engine(preset: str, robots: int, steps: int = 6) -> DistributedEngine:
    scenario = dataclasses.replace(PRESETS[preset](), robots=robots)
    engine = DistributedEngine(scenario)
    engine.run(steps)
    return engine


def _built(engine: DistributedEngine, rid: int) -> dict[str, object]:
    agent = engine.agents[rid]
    decision = Decision(goal=np.asarray(agent.position, float),
                        power_weight=float(agent.power_weight))
    step = Step(agent, engine.step_index - 1, decision, np.empty((0, 2)), 0.5, "map")
    return {o.topic: load_face(o).build(step, {})
            for o in declared_outputs(engine.scenario.system)}


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_every_declared_output_of_every_system_is_built_with_its_declared_type(preset):
    engine = _engine(preset, robots=2, steps=3)
    outputs = declared_outputs(engine.scenario.system)
    for o in outputs:
        msg = _built(engine, 0)[o.topic]
        assert f"{type(msg).__module__.split('.')[0]}/msg/{type(msg).__name__}" == o.type


def test_grid_windows_read_back_into_the_engine_s_team_density():
    engine = _engine("dames_static", robots=3)
    reader = TeamReader(engine.scenario.system)
    assert (reader.image, reader.inputs, reader.figures) == ("density", ("density",), None)
    windows = {r: _built(engine, r)["density"] for r in engine.agents}
    image = add_windows(engine.grid, windows, lambda r, e: pytest.fail(str(e)))
    team = np.zeros(engine.grid.size)
    for agent in engine.agents.values():
        team[agent.exchange.bins] += agent.exchange.weights
    np.testing.assert_array_equal(image.ravel(), team)


def test_a_window_off_the_grid_is_passed_to_the_error_callback():
    grid = PRESETS["dames_static"]().grid
    bad = convert.density_grid(1, 0, grid, np.array([0]), np.array([1.0]), 0.5, "map")
    bad.width += 1
    errors = []
    image = add_windows(grid, {1: bad}, lambda rid, exc: errors.append((rid, str(exc))))
    assert not image.any() and errors and errors[0][0] == 1


def test_mixtures_and_tracks_read_back_bit_for_bit_into_the_figures_view():
    engine = _engine("sung_tokekar", robots=1, steps=12)
    reader = TeamReader(engine.scenario.system)
    assert reader.inputs == ("estimates", "components", "tracks")
    assert reader.figures is not None and reader.image == ""
    built = _built(engine, 0)
    est = engine.agents[0].estimator
    points = np.asarray(est.estimates(), float).reshape(-1, 2)
    built["estimates"] = convert.target_set(0, 1, np.arange(len(points)), points,
                                            est.expected_count(), 0.5, "map")
    robot = reader.read_robot(built)
    (view,) = reader.views({0: robot})
    np.testing.assert_array_equal(view.mixture.weights, est.mixture.weights)
    np.testing.assert_array_equal(view.mixture.covs, est.mixture.covs)
    for got, want in zip(view.targets(), est.targets(), strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(view.confirmed_mask(), est.confirmed_mask())
    estimates, expected = union({0: robot})
    np.testing.assert_array_equal(estimates, points)
    assert expected == est.expected_count()


def test_union_joins_robots_in_id_order_and_estimates_are_checked():
    a = (np.array([[1.0, 2.0]]), 0.5)
    b = (np.array([[3.0, 4.0], [5.0, 6.0]]), 1.25)
    points, expected = union({7: {"estimates": b}, 2: {"estimates": a}})
    np.testing.assert_array_equal(points, [[1, 2], [3, 4], [5, 6]])
    assert expected == 1.75
    msg = TargetSet(expected_cardinality=float("nan"))
    with pytest.raises(convert.InvalidMessage, match="expected_cardinality"):
        read_estimates(msg)


def test_a_face_of_another_type_or_no_face_is_refused():
    out = Output("density", "phd_swarm_msgs/msg/TargetSet",
                 "phd_swarm.nodes.faces.grid_phd:DENSITY", "x")
    with pytest.raises(ValueError, match="declared as phd_swarm_msgs/msg/TargetSet but its "
                                         "face .* builds phd_swarm_msgs/msg/DensityGrid"):
        load_face(out)
    with pytest.raises(ValueError, match="is a dict, not a Face"):
        load_face(Output("x", "a/msg/B", "phd_swarm.nodes.faces.voronoi_phd:TYPES", "x"))
    with pytest.raises(ValueError, match="cannot be loaded: ModuleNotFoundError"):
        load_face(Output("x", "a/msg/B", "phd_swarm.nodes.no_such:X", "x"))
    assert isinstance(load_face(Output("density", "phd_swarm_msgs/msg/DensityGrid",
                                       "phd_swarm.nodes.faces.grid_phd:DENSITY", "x")), Face)
    assert load_face(Output("density", "phd_swarm_msgs/msg/DensityGrid",
                            "phd_swarm.nodes.faces.grid_phd:DENSITY", "x")).msg_type \
        is DensityGrid


def test_a_window_adds_alike_as_a_message_and_as_the_codecs_dict():
    """The monitor decodes windows with the numpy codec; the log readers take messages."""
    from rclpy.serialization import serialize_message

    from phd_swarm.nodes import cdr

    engine = _engine("dames_static", robots=3)
    grid = engine.scenario.grid
    msgs = {r: _built(engine, r)["density"] for r in range(3)}
    dicts = {r: cdr.decode(DensityGrid, serialize_message(m)) for r, m in msgs.items()}
    errors: list[int] = []
    as_msgs = add_windows(grid, msgs, lambda rid, exc: errors.append(rid))
    assert np.array_equal(add_windows(grid, dicts, lambda rid, exc: errors.append(rid)),
                          as_msgs) and as_msgs.sum() > 0 and errors == []
    wide = dict(dicts[0], origin_col=grid.shape[1])
    with pytest.raises(convert.InvalidMessage, match="beyond the grid"):
        convert.add_density(np.zeros(grid.shape), wide, grid)
