"""A scenario from a nested mapping (a YAML file): a preset plus overrides.

:func:`scenario_from_dict` takes a preset of :data:`phd_swarm.sim.presets.PRESETS` and
overrides its fields; it rejects unknown keys, wrong types and values out of range with an
error that names the key and the file.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path
from typing import Any

from phd_swarm.core.geometry.grid import Environment
from phd_swarm.core.models import PhdModels
from phd_swarm.core.params import (
    expect_bool,
    expect_box,
    expect_int,
    expect_list,
    expect_mapping,
    expect_number,
    expect_str,
)
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.presets import PRESETS
from phd_swarm.sim.scenario import Scenario, TargetConfig

#: A list of boxes (``targets.clusters``) and of counts (``targets.per_cluster``).
_boxes = partial(expect_list, item=expect_box)
_counts = partial(expect_list, item=partial(expect_int, low=0))


def _optional_number(value: Any, path: str) -> float | None:
    """None (the field unset), or a number."""
    return None if value is None else expect_number(value, path)


# Value parsers of scenario_from_dict: (value, key path) -> the field's value, converted (a
# float for a number); the ranges are checked by the dataclasses.
_TARGET_PARSERS: dict[str, Callable[[Any, str], Any]] = {
    "kind": expect_str, "count": expect_int, "draw_box": expect_box, "speed": expect_number,
    "heading_sd": expect_number, "heading_rate": expect_number, "birth": expect_bool,
    "birth_heading": expect_str, "clusters": _boxes, "per_cluster": _counts,
    "step_sd": expect_number, "max_speed": expect_number, "turn_every": expect_number,
    "layout_seed": lambda v, path: None if v is None else expect_int(v, path, low=0),
    "spawn": expect_str, "lifetime_mean": expect_number, "birth_spread": expect_number,
    "process_noise": expect_number, "noise_form": expect_str, "lifetime_model": expect_str}

_SCALAR_PARSERS: dict[str, Callable[[Any, str], Any]] = {
    "name": expect_str, "resolution": expect_number, "dt": expect_number,
    "duration": expect_number, "robots": expect_int, "robot_start_box": expect_box,
    "robot_max_speed": expect_number, "extraction_threshold": expect_number,
    "ospa_c": expect_number, "ospa_p": partial(expect_number, allow_inf=True),
    "seed": expect_int, "robot_start_grid": _optional_number}

_MODEL_PARTS = ("detection", "measurement", "clutter", "motion", "survival", "birth")


def _merge_env(base: Environment, value: Any, path: str) -> Environment:
    names = [f.name for f in dataclasses.fields(Environment)]
    cfg = expect_mapping(value, path, names)
    kw = {k: expect_number(v, f"{path}.{k}") for k, v in cfg.items()}
    try:
        return dataclasses.replace(base, **kw)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _merge_models(base: PhdModels, value: Any, path: str) -> PhdModels:
    cfg = expect_mapping(value, path, (*_MODEL_PARTS, "initial_density"))
    kw: dict[str, Any] = {}
    try:
        for part in _MODEL_PARTS:
            if part not in cfg:
                continue
            current = getattr(base, part)
            sub = expect_mapping(cfg[part], f"{path}.{part}",
                                 [f.name for f in dataclasses.fields(current)])
            kw[part] = dataclasses.replace(
                current, **{k: expect_number(v, f"{path}.{part}.{k}") for k, v in sub.items()})
        if "initial_density" in cfg:
            kw["initial_density"] = expect_number(cfg["initial_density"],
                                                  f"{path}.initial_density")
        return dataclasses.replace(base, **kw)
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(path) else f"{path}.{msg}") from None


def _merge_targets(base: TargetConfig, value: Any, path: str) -> TargetConfig:
    cfg = expect_mapping(value, path, list(_TARGET_PARSERS))
    kw = {k: _TARGET_PARSERS[k](v, f"{path}.{k}") for k, v in cfg.items()}
    return dataclasses.replace(base, **kw)


def preset_name(d: Mapping[str, Any]) -> str:
    """The preset ``d["preset"]`` names; ValueError ``preset: ...`` if missing or unknown."""
    if "preset" not in d:
        raise ValueError(f"preset: missing; expected one of {sorted(PRESETS)}")
    return expect_str(d["preset"], "preset", choices=sorted(PRESETS))


def scenario_from_dict(d: Mapping[str, Any], where: str = "scenario",
                       base_dir: str | Path | None = None) -> Scenario:
    """Build a scenario from a nested mapping: a preset plus overrides.

    ``d["preset"]`` names one of :data:`PRESETS`; every other key overrides the field of
    the same name. ``env``, ``models`` and ``targets`` are mappings merged key by key into
    the preset's (e.g. ``{"models": {"detection": {"p_d": 0.9}}}`` keeps the preset's
    radius); ``system`` names the parts and options (:class:`SystemConfig`). Boxes are
    lists of four numbers, ``clusters`` a list of boxes.

    Parameters
    ----------
    d : Mapping
        E.g. a parsed YAML document.
    where : str
        Names the source (e.g. the file) in error messages.
    base_dir : path, optional
        Directory relative plugin files of ``system.plugins`` are taken from (the config
        file's).

    Returns
    -------
    Scenario
        The validated scenario.

    Raises
    ------
    ValueError
        For a missing or unknown preset, an unknown key, a value of the wrong type or out
        of range; the message starts with ``where`` and names the key path (e.g.
        ``runs/a.yaml: targets.speed: expected a number, got 'fast'``).
    """
    try:
        allowed = ("preset", "env", "models", "targets", "system", *_SCALAR_PARSERS)
        cfg = expect_mapping(d, "", allowed)
        base = PRESETS[preset_name(cfg)]()
        kw: dict[str, Any] = {k: _SCALAR_PARSERS[k](v, k) for k, v in cfg.items()
                              if k in _SCALAR_PARSERS}
        if "env" in cfg:
            kw["env"] = _merge_env(base.env, cfg["env"], "env")
        if "models" in cfg:
            kw["models"] = _merge_models(base.models, cfg["models"], "models")
        if "targets" in cfg:
            kw["targets"] = _merge_targets(base.targets, cfg["targets"], "targets")
        if "system" in cfg:
            kw["system"] = SystemConfig.from_dict(cfg["system"], "system", base_dir)
        return base.with_overrides(**kw)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


__all__ = ["preset_name", "scenario_from_dict"]
