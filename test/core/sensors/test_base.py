"""Every built-in sensor part's instance is a :class:`Sensor`, and its hooks draw as before."""

from __future__ import annotations

import ast
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from phd_swarm.core import registry
from phd_swarm.core.models import DiskDetection, PhdModels, UniformClutter
from phd_swarm.core.sensors import disk, disk_false_positive, disk_labelled, square_range_bearing
from phd_swarm.core.sensors.base import LabellingSensor, Sensor

SENSORS = Path(__file__).resolve().parents[3] / "phd_swarm" / "core" / "sensors"
MODELS = PhdModels(detection=DiskDetection(p_d=0.8, radius=5.0),
                   clutter=UniformClutter(density=0.05))


class _System:
    """The options a part reads: its defaults, or ``options``."""

    def __init__(self, part, **options):
        self.part, self.options = part, options

    def option(self, name):
        return self.options.get(name, next(s.default for s in self.part.options
                                           if s.name == name))


def _instance(name: str, **options):
    part = registry.lookup("sensor", name)
    return part, part.make(part.setup(SimpleNamespace(models=MODELS),
                                      _System(part, **options)), 0)


#: Each built-in sensor and the module function its instance's scans must equal.
SIMULATE = {
    "disk": lambda rng, inst, pose, x: disk.simulate_scan(rng, MODELS, pose, x),
    "disk_labelled": lambda rng, inst, pose, x: disk_labelled.simulate_scan(rng, MODELS,
                                                                            pose, x),
    "disk_false_positive": disk_false_positive.simulate_scan,
    "square_range_bearing": square_range_bearing.simulate_scan,
}


@pytest.mark.parametrize("name", sorted(SIMULATE))
def test_the_instance_is_a_sensor_and_the_hook_draws_its_module_s_scan(name):
    part, inst = _instance(name, false_positive_prob=0.7)
    assert isinstance(inst, Sensor)
    targets = np.random.default_rng(1).uniform(-6.0, 6.0, (10, 2))
    a, b = np.random.default_rng(4), np.random.default_rng(4)
    for k in range(5):
        pose = np.array([0.5 * k, -0.25 * k])
        np.testing.assert_array_equal(part.simulate(a, inst, pose, targets),
                                      SIMULATE[name](b, inst, pose, targets))
    assert a.random() == b.random()                  # the stream is left in the same state


def test_the_labelled_disk_reads_tags_through_its_hook():
    part, inst = _instance("disk_labelled")
    assert isinstance(inst, LabellingSensor)
    assert not isinstance(_instance("disk")[1], LabellingSensor)
    targets, ids = np.array([[1.0, 0.0], [30.0, 0.0]]), np.array([4, 9])
    z, labels = part.simulate_labelled(np.random.default_rng(2), inst, np.zeros(2), targets,
                                       ids)
    zz, ll = disk_labelled.simulate_labelled_scan(np.random.default_rng(2), MODELS,
                                                  np.zeros(2), targets, ids)
    np.testing.assert_array_equal(z, zz)
    np.testing.assert_array_equal(labels, ll)


def test_detection_probability_is_p_d_in_the_field_of_view():
    points = np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 4.001], [5.0, 5.0], [5.0, 5.001]])
    pose = np.zeros(2)
    for name in ("disk", "disk_labelled", "disk_false_positive"):
        # the closed disk of radius 5 m, p_d = 0.8 (Dames eq. 9)
        np.testing.assert_array_equal(_instance(name)[1].detection_probability(points, pose),
                                      [0.8, 0.8, 0.0, 0.0, 0.0])
    # the closed square of side 10 m, p_D^max = 0.99 (Papaioannou eq. 5)
    np.testing.assert_array_equal(
        _instance("square_range_bearing")[1].detection_probability(points, pose),
        [0.99, 0.99, 0.99, 0.99, 0.0])


def _imported(path: Path) -> list[str]:
    """The absolute module of every import in a module of ``core/sensors``."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = ["phd_swarm", "core", "sensors"][:4 - node.level] if node.level else []
            out.append(".".join(base + ([node.module] if node.module else [])))
    return out


def test_no_sensor_module_imports_an_estimator():
    """A sensor's model is the sensor's: the estimators import it, never the other way."""
    modules = sorted(SENSORS.glob("*.py"))
    assert len(modules) >= 7
    for path in modules:
        up = [m for m in _imported(path) if m.startswith("phd_swarm.core.estimators")]
        assert not up, f"{path.name} imports {up}"
