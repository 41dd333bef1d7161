"""Generated docs: up to date, complete, and --check catches stale or missing files."""

from __future__ import annotations

from pathlib import Path

import pytest

from phd_swarm.config import node_params
from phd_swarm.core import registry
from phd_swarm.nodes import topics
from phd_swarm.tools import gen_docs

ROOT = Path(__file__).resolve().parents[2]


def test_generated_docs_are_up_to_date():
    problems = gen_docs.check(ROOT)
    assert problems == [], ("docs are stale; run `python -m phd_swarm.tools.gen_docs`:\n"
                            + "\n".join(problems))


def test_every_topic_has_a_description_and_every_declared_output_is_shown():
    shown = gen_docs.documented_topics()
    fixed = {name for name, _, _ in shown[:len(topics.TEAM_TOPICS)]} | {
        gen_docs.ROBOT_PATTERN.format(rel) for rel in topics.ROBOT_TOPICS}
    assert fixed == set(gen_docs.DESCRIPTIONS), "descriptions and fixed topics differ"
    assert all(text.strip() for _, _, text in shown)
    declared = {o.topic for role in registry.ROLES for name in registry.names(role)
                for o in registry.lookup(role, name).outputs}
    assert {"density", "cell", "components", "markers", "plan"} <= declared
    assert {name for name, _, _ in shown} == fixed | {
        gen_docs.ROBOT_PATTERN.format(t) for t in declared}
    # markers: one row for the Gaussian-mixture estimators, one for the agents' controller
    rows = [spec for name, spec, _ in shown if name == "/robot_<id>/markers"]
    assert len(rows) == 2 and "sung_gmphd" in rows[0][3] + rows[1][3]


def test_every_scenario_key_has_a_meaning():
    # Part options are documented with the parts (the options table), not as scenario keys.
    keys = {k for flat in gen_docs.scenario_defaults().values() for k in flat
            if not k.startswith("system.options.")}
    assert keys - set(gen_docs.SCENARIO_MEANINGS) == set(), "scenario keys without a meaning"
    assert set(gen_docs.SCENARIO_MEANINGS) - keys == set(), "meanings of no scenario key"


def test_every_topic_parameter_and_key_is_in_the_text():
    text = gen_docs.render_topics()
    for name, (typ, qos_name, _, _), _ in gen_docs.documented_topics():
        row = next(line for line in text.splitlines() if line.startswith(f"| `{name}` |"))
        assert f"`{typ}`" in row and f"`{qos_name}`" in row
    params = gen_docs.render_parameters()
    for _, _, specs in gen_docs.NODE_TABLES:
        for spec in specs:
            assert f"| `{spec.name}` |" in params
    for key in gen_docs.SCENARIO_MEANINGS:
        assert f"| `scenario.{key}` |" in params
    assert set(node_params.NODES.values()) <= {s for _, _, s in gen_docs.NODE_TABLES}


def test_a_target_field_shows_only_for_the_presets_whose_kind_uses_it():
    presets = list(gen_docs.scenario_defaults())
    rows = {line.split(" | ")[0].strip("| `"): line.split(" | ")[1:1 + len(presets)]
            for line in gen_docs.render_parameters().splitlines()
            if line.startswith("| `scenario.targets.")}
    kinds = [gen_docs.scenario_defaults()[p]["targets.kind"] for p in presets]
    for key, kind in [("scenario.targets.birth_heading", "dames_walk"),
                      ("scenario.targets.step_sd", "clustered_walk"),
                      ("scenario.targets.draw_box", "static")]:
        shown = [value != "-" for value in rows[key]]
        assert shown == [k == kind for k in kinds], key
    assert all(value != "-" for value in rows["scenario.targets.count"])


def test_qos_summary_resolves_writer_and_reader():
    assert gen_docs.qos_summary("INBOX") == \
        "reliable, transient local, depth 64 (writer) / depth 1000 (reader)"
    assert gen_docs.qos_summary("LATCHED") == "reliable, transient local, depth 1"
    assert gen_docs.qos_summary("STEP") == \
        "reliable, transient local, depth 512 (writer) / keep all (reader)"


def test_check_finds_stale_and_missing_files(tmp_path):
    assert gen_docs.check(tmp_path) == ["docs/topics.md: missing", "docs/parameters.md: missing"]
    assert gen_docs.main(["--check", "--root", str(tmp_path)]) == 1
    assert gen_docs.main(["--root", str(tmp_path)]) == 0
    assert gen_docs.check(tmp_path) == []
    assert gen_docs.main(["--check", "--root", str(tmp_path)]) == 0

    path = tmp_path / "docs" / "topics.md"
    path.write_text(path.read_text().replace("# Topics", "# Topix"))
    problems = gen_docs.check(tmp_path)
    assert problems[0] == "docs/topics.md: out of date (2 lines differ)"
    assert "-# Topix" in problems and "+# Topics" in problems
    assert gen_docs.write(tmp_path) == [path]
    assert gen_docs.write(tmp_path) == []


def test_a_missing_description_fails_the_render(monkeypatch):
    # Copies without the key (deleting and restoring an item would move it to the end of
    # the dict, and so its row in the docs of every later render in this process).
    monkeypatch.setattr(gen_docs, "DESCRIPTIONS", {
        k: v for k, v in gen_docs.DESCRIPTIONS.items() if k != topics.CLOCK})
    with pytest.raises(ValueError, match="/clock"):
        gen_docs.render_topics()
    monkeypatch.setattr(gen_docs, "SCENARIO_MEANINGS", {
        k: v for k, v in gen_docs.SCENARIO_MEANINGS.items() if k != "dt"})
    with pytest.raises(ValueError, match="'dt'"):
        gen_docs.render_parameters()


def test_a_plugin_loaded_in_this_process_stays_out_of_the_docs(tmp_path):
    from phd_swarm.core import registry

    plugin = tmp_path / "docs_probe_parts.py"
    plugin.write_text("from phd_swarm.core import registry\n"
                      "registry.register('controller', 'docs_probe', lambda s, r: None,\n"
                      "                  description='not ours')\n")
    registry.load_plugins([str(plugin)])
    try:
        assert "docs_probe" not in gen_docs.render_parameters()
    finally:
        registry._PARTS["controller"].pop("docs_probe")


def test_every_preset_and_target_kind_is_named_where_users_read_them():
    from phd_swarm.sim.presets import PRESETS
    from phd_swarm.sim.scenario import TARGET_KINDS

    params = gen_docs.render_parameters()
    for name in PRESETS:
        assert name in gen_docs.SCENARIO_MEANINGS["preset"], name
    for kind in TARGET_KINDS:
        assert kind in gen_docs.SCENARIO_MEANINGS["targets.kind"], kind
    assert all(name in params for name in PRESETS)
