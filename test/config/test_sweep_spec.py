"""Sweep specs: variants of a spec (``base:``), labels, and what the config hash covers."""

from __future__ import annotations

import dataclasses
import shutil
import sys
from pathlib import Path

import pytest

from phd_swarm.config import sweep_spec
from phd_swarm.config.sweep_spec import SpecError, config_hash, find_spec, load_spec
from phd_swarm.core import registry
from phd_swarm.core.params import ParamSpec
from phd_swarm.sim.presets import PRESETS

ROOT = Path(__file__).resolve().parents[2]

#: A 30 x 30 m map, 2 team sizes x 2 methods, 15 steps each.
BASE = """\
preset: dames_static
name: not_inherited
figure: tiny base
methods: {PHD: phd, uniform: uniform}
robots: [2, 3]
targets: [6]
trials: 2
duration: 7.5
scenario:
  env: {xmin: 0, ymin: 0, xmax: 30, ymax: 30}
  robot_start_box: [10, 0, 20, 5]
  targets: {draw_box: [-3, -3, 33, 33]}
quick: {robots: [2], trials: 1}
"""


# ------------------------------------------------------------------------------ base:
def test_a_variant_is_its_base_with_the_keys_it_gives_replaced(tmp_path):
    (tmp_path / "tiny.yaml").write_text(BASE)
    variant = tmp_path / "tiny_far.yaml"
    variant.write_text("base: tiny\nfigure: tiny, far sensor\nrobots: [4]\n"
                       "scenario: {targets: {layout_seed: 3}, models: {detection: "
                       "{p_d: 0.5}}}\n")
    base, spec = load_spec(tmp_path / "tiny.yaml"), load_spec(variant)
    # Its own name (the base's name: is not inherited), so its own output folder.
    assert spec.name == spec.label == "tiny_far" and spec.base == "tiny"
    assert spec.figure == "tiny, far sensor" and spec.robots == (4,)
    assert spec.methods == base.methods and spec.trials == 2 and spec.duration == 7.5
    # scenario: merged key by key, down to the targets' mapping.
    assert spec.scenario == {"env": {"xmin": 0, "ymin": 0, "xmax": 30, "ymax": 30},
                             "robot_start_box": [10, 0, 20, 5],
                             "targets": {"draw_box": [-3, -3, 33, 33], "layout_seed": 3},
                             "models": {"detection": {"p_d": 0.5}}}
    assert spec.base_scenario().targets.draw_box == base.base_scenario().targets.draw_box
    assert spec.base_scenario().models.detection.p_d == 0.5
    # quick: is the base's, applied over the variant's own keys.
    quick = load_spec(variant, quick=True)
    assert quick.robots == (2,) and quick.trials == 1 and quick.label == "tiny_far_quick"
    assert spec.to_dict()["base"] == "tiny" and "base" not in base.to_dict()


def test_a_variant_of_a_variant_and_of_a_repository_spec(tmp_path):
    # The reading variants of issue 33: one system option more, the rest the base's.
    shutil.copy(find_spec("sung_fov_rule"), tmp_path / "sung_fov_rule.yaml")
    (tmp_path / "sung_push.yaml").write_text(
        "base: sung_fov_rule\nscenario: {system: {options: {fov_push_to: threshold}}}\n")
    (tmp_path / "sung_push_short.yaml").write_text(
        "base: sung_push\nquick: {trials: 1, duration: 300.0, window: [0.0, 300.0]}\n")
    orig = load_spec(find_spec("sung_fov_rule"))
    push = load_spec(tmp_path / "sung_push.yaml")
    assert push.methods == orig.methods and push.engine == orig.engine == "distributed"
    assert push.label == "sung_push"
    for t in push.trials_list():
        assert t.scenario.system.option("fov_push_to") == "threshold"
    short = load_spec(tmp_path / "sung_push_short.yaml", quick=True)
    assert short.trials == 1 and short.duration == 300.0 and short.base == "sung_push"
    assert {t.scenario.system.option("fov_push_to") for t in short.trials_list()} == {
        "threshold"}


@pytest.mark.parametrize(("files", "message"), [
    ({"v": "base: nope\n"}, "v.yaml: base: unknown spec 'nope'; expected one of ['tiny']"),
    ({"v": "base: ../other/tiny\n"}, "v.yaml: base: expected the name of a spec in the "
                                     "same folder"),
    ({"v": "base: [tiny]\n"}, "v.yaml: base: expected the name of a spec"),
    ({"v": "base: v\n"}, "v.yaml: base: 'v' makes a cycle (v -> v)"),
    ({"v": "base: w\n", "w": "base: v\n"}, "w.yaml: base: 'v' makes a cycle (v -> w -> v)"),
    ({"v": "base: tiny\nrobots: [ten]\n"}, "v.yaml: robots[0]: expected an integer"),
    ({"v": "base: w\n", "w": "base: tiny\nmetric: best\n"}, "w.yaml: metric: expected one of"),
])
def test_bad_bases_name_the_file_and_the_key(tmp_path, files, message):
    (tmp_path / "tiny.yaml").write_text(BASE)
    for name, text in files.items():
        (tmp_path / f"{name}.yaml").write_text(text)
    with pytest.raises(SpecError) as exc:
        load_spec(tmp_path / "v.yaml")
    # The error names the file where it is (the variant's, or a bad base's own).
    assert str(exc.value).startswith(f"{tmp_path}/{message}"), str(exc.value)


def test_a_base_is_looked_up_in_the_variants_own_folder(tmp_path):
    (tmp_path / "tiny.yaml").write_text(BASE)
    (tmp_path / "sub").mkdir()
    variant = tmp_path / "sub" / "v.yaml"
    variant.write_text("base: tiny\n")
    with pytest.raises(SpecError, match=r"sub/v.yaml: base: unknown spec 'tiny'"):
        load_spec(variant)


# ------------------------------------------------------------------------------ labels
def test_the_output_folder_is_suffixed_only_for_another_engine_than_the_specs():
    # The committed rows of a spec are in results/sweeps/<name> whichever its engine.
    sung = find_spec("sung_planners")
    assert load_spec(sung).label == "sung_planners"
    assert load_spec(sung, engine="distributed").label == "sung_planners"
    assert load_spec(sung, engine="central").label == "sung_planners_central"
    assert load_spec(sung, quick=True).label == "sung_planners_quick"
    assert load_spec(sung, quick=True, engine="central").label == "sung_planners_quick_central"
    dames = find_spec("dames_static")
    assert load_spec(dames, engine="central").label == "dames_static"
    assert load_spec(dames, engine="distributed").label == "dames_static_distributed"


# ------------------------------------------------------------------------ config hash
@pytest.fixture
def probe(monkeypatch):
    """A controller ``probe`` with option ``probe_rule`` (default ``new``), for this test."""
    monkeypatch.setitem(registry._PARTS, "controller", dict(registry._PARTS["controller"]))
    part = registry.register(
        "controller", "probe", _make_probe, description="test part",
        options=(ParamSpec("probe_rule", "new", "test option", choices=("old", "new")),))
    return part


def _make_probe(setup, robot_id):
    return None


def _probe_hash(**options) -> str:
    sc = PRESETS["dames_static"]().with_system(controller="probe", options=options)
    return config_hash(sc, "probe", "final", (0.0, 10.0))


def test_a_later_option_enters_the_hash_with_its_effective_value(probe, monkeypatch):
    # The method text says it all (the system is not hashed): the part's default of a
    # later option still enters, unless it is the value of the rows from before it.
    monkeypatch.setitem(sweep_spec._LATER_OPTIONS, "probe_rule", "new")
    as_before = _probe_hash()
    monkeypatch.setitem(sweep_spec._LATER_OPTIONS, "probe_rule", "old")
    assert _probe_hash() != as_before
    assert _probe_hash(probe_rule="old") != _probe_hash()


def test_a_later_option_at_its_old_value_does_not_enter_the_hash(monkeypatch):
    # Sung & Tokekar's system is hashed; fov_push_to (default paper) came later.
    sc = PRESETS["sung_tokekar"]().with_system(controller="lawnmower", options={})

    def h(push_to: str | None = None) -> str:
        s = sc if push_to is None else sc.with_system(options={"fov_push_to": push_to})
        return config_hash(s, "lawnmower", "mean", (0.0, 10.0))

    assert sweep_spec._LATER_OPTIONS["fov_push_to"] == "paper"
    unset = h()
    assert h("paper") == unset and h("threshold") != unset
    # Had the old results been made with `threshold`, the default would now enter, and a
    # system set to `threshold` would hash as one without the option.
    monkeypatch.setitem(sweep_spec._LATER_OPTIONS, "fov_push_to", "threshold")
    assert h() != unset and h("threshold") == unset


def test_a_results_revision_above_one_enters_the_hash(probe, monkeypatch):
    first = _probe_hash()
    assert sweep_spec.results_revisions(
        PRESETS["dames_static"]().with_system(controller="probe").system) == {
        "sensor.disk": 1, "estimator.grid_phd": 1, "exchange.voronoi_phd": 1,
        "controller.probe": 1}
    # Declared by the module of the part's make ...
    monkeypatch.setattr(sys.modules[__name__], "RESULTS_REVISION", 2, raising=False)
    second = _probe_hash()
    assert second != first
    # ... or by the part itself, which wins.
    def declare(n: int) -> None:
        monkeypatch.setitem(registry._PARTS["controller"], "probe",
                            dataclasses.replace(probe, results_revision=n))

    declare(1)
    assert _probe_hash() == first
    declare(3)
    assert _probe_hash() not in (first, second)
    declare(0)
    with pytest.raises(ValueError, match="system.controller: probe declares results "
                                         "revision 0; expected an integer >= 1"):
        _probe_hash()


def test_chen_readings_options_hash_as_before_at_their_defaults():
    # Issue 34: rho_cap (chen_p, chen_o), extraction_window and extraction_radius
    # (grid_phd) came after chen_clustered's rows; at their defaults a system hashes as
    # without them, whether the method text says it all or the system is hashed.
    for name, old in (("rho_cap", "fixed"), ("extraction_window", 3.0),
                      ("extraction_radius", 0.0)):
        assert sweep_spec._LATER_OPTIONS[name] == old
    chen = PRESETS["chen_clustered"]()
    for method in ("chen_o", "chen_p"):
        plain = config_hash(chen.with_system(controller=method), method, "median", (1, 2))
        explicit = chen.with_system(controller=method, options={
            "rho_cap": "fixed", "extraction_window": 3.0, "extraction_radius": 0.0})
        assert config_hash(explicit, method, "median", (1, 2)) == plain
        guarded = chen.with_system(controller=method, options={"rho_cap": "nearest_robot"})
        assert config_hash(guarded, method, "median", (1, 2)) != plain
    # A system set under scenario: (hashed whole) keeps its hash too.
    o = chen.with_system(controller="chen_o", estimator="grid_phd", options={"rho_max": 5})
    assert config_hash(o, "chen_o", "median", (1, 2)) == config_hash(
        o.with_system(options={"extraction_radius": 0.0}), "chen_o", "median", (1, 2))


def test_the_chen_readings_specs_share_chen_clustereds_rows_and_take_the_new_options():
    readings = load_spec(find_spec("chen_readings"))
    assert readings.methods["P_cap10"] == "chen_p(rho_max=10.0)"
    assert readings.methods["O_lit_guard"] == \
        "chen_o(cumulative_mode=literal,rho_cap=nearest_robot)"
    assert readings.methods["D_r1"] == "phd(extraction_radius=1.0)"
    trials = {t.key: t for t in readings.trials_list()}
    assert trials["P_cap7_5_r070_t060_res1_s0"].scenario.system.option("rho_max") == 7.5
    assert trials["D_r1_r070_t060_res1_s0"].scenario.extraction.radius_m == 1.0
    # D, P and O are chen_clustered's trials at 70 robots: same keys, same hashes.
    clustered = {t.key: t.config_hash for t in load_spec(find_spec("chen_clustered"))
                 .trials_list()}
    shared = [k for k in trials if k.split("_r070")[0] in ("D", "P", "O")]
    assert len(shared) == 30 and all(clustered[k] == trials[k].config_hash for k in shared)
    step = load_spec(find_spec("chen_dt025")).trials_list()[0].scenario
    assert (step.dt, step.steps, step.models.motion.sd, step.targets.step_sd) == \
        (0.25, 4000, 0.277, 1.5)
    assert step.models.motion.kernel(1.0).shape == (3, 3), "the filter still moves mass"
    fine = load_spec(find_spec("chen_extraction_fine")).trials_list()
    assert {t.scenario.extraction.window_bins(t.scenario.grid) for t in fine} == {3, 7}
