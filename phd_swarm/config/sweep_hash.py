"""The config hash of a sweep trial, and the method texts it covers.

A trial's row in ``results.csv`` carries :func:`config_hash`: 16 hex digits over everything
that decides its result (the scenario, the method text, the metric and window, the engine,
the system where the method text does not say it all). ``scripts/sweep.sh`` resumes only
rows whose hash is the spec's and refuses to mix others (docs/sweeps.md, "How the committed
results stay honest"). Two rules keep committed rows valid as the code grows:

- a part option added later enters the hash by its effective value (the option set, or its
  part's default) only where that differs from the value that reproduces the committed
  rows (:data:`_LATER_OPTIONS`, :func:`later_options`);
- a part whose bug fix changes its results declares ``RESULTS_REVISION`` > 1, which enters
  the hash (:func:`results_revisions`), so its old rows stop matching.

The method text (:func:`controller_name`, :func:`method_system`) is the ``controller``
column of results.csv: ``controller`` or ``controller(key=value,...)``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import sys
from collections.abc import Mapping
from typing import Any

from phd_swarm.core.registry import ROLES
from phd_swarm.core.system import SystemConfig
from phd_swarm.sim.scenario import Scenario

#: Part options added after results that use their parts were committed, with the default
#: that reproduces those results: at that default they do not enter the hash.
_LATER_OPTIONS = {"fov_push_to": "paper", "merge_metric": "candidate",
                  "overlap_threshold_form": "sum", "reward_union": "position",
                  "gp_input": "estimates", "rho_cap": "fixed", "extraction_window": 3.0,
                  "extraction_radius": 0.0}


def config_hash(scenario: Scenario, controller: str, metric: str,
                window: tuple[float, float], engine: str = "central") -> str:
    """16 hex digits of SHA-256 over the scenario's fields, controller, metric and engine.

    The scenario's system enters through the method text ``controller``; the system itself
    is hashed only where it differs from what that text says (other parts, options or
    plugins set under ``scenario:``), so the hashes of results from before the system
    block existed stay valid.

    Two things keep a stored row honest when the code changes under it:

    - An option of :data:`_LATER_OPTIONS` enters with its effective value (the one set, or
      the default of the part that declares it), unless that value is the one that
      reproduces the rows from before the option existed.
    - A part's results revision (:func:`results_revisions`) enters once it is above 1,
      so a bug fix that changes a part's results orphans that part's rows.
    """
    fields = dataclasses.asdict(scenario)
    fields.pop("system")
    # Fields added after results were committed enter only where they matter, so the
    # hashes of those results stay valid.
    if scenario.targets.kind != "turning_walk":
        fields["targets"].pop("turn_every")
    if scenario.robot_start_grid is None:
        fields.pop("robot_start_grid")
    if scenario.targets.layout_seed is None:
        fields["targets"].pop("layout_seed")
    if scenario.targets.kind != "ncv":
        for name in ("spawn", "lifetime_mean", "birth_spread", "process_noise", "noise_form"):
            fields["targets"].pop(name)
    if scenario.targets.kind != "ncv" or scenario.targets.lifetime_model == "cut":
        fields["targets"].pop("lifetime_model")
    doc = {"scenario": _plain(fields), "controller": controller,
           "metric": metric, "window": [float(w) for w in window], "engine": engine}
    try:
        implied = SystemConfig().with_parts(**method_system(controller))
    except ValueError:  # the method's parts do not fit the default system's others
        implied = None
    later = {name: value for name, value in later_options(scenario.system).items()
             if value != _LATER_OPTIONS[name]}
    if scenario.system != implied:
        doc["system"] = _plain(scenario.system.to_dict())
        for name in _LATER_OPTIONS:
            doc["system"]["options"].pop(name, None)
        doc["system"]["options"].update(later)
    elif later:
        doc["later_options"] = later
    revisions = {part: n for part, n in results_revisions(scenario.system).items() if n > 1}
    if revisions:
        doc["revisions"] = revisions
    text = json.dumps(doc, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def later_options(system: SystemConfig) -> dict[str, Any]:
    """Effective value of each :data:`_LATER_OPTIONS` option that ``system``'s parts take.

    The value set in ``system.options``, else the default of the
    :class:`~phd_swarm.core.params.ParamSpec` of the part that declares the option.
    """
    declared = {spec.name: spec for part in system.parts().values() for spec in part.options}
    given = dict(system.options)
    return {name: given.get(name, declared[name].default)
            for name in _LATER_OPTIONS if name in declared}


def results_revisions(system: SystemConfig) -> dict[str, int]:
    """``role.name`` -> results revision of each of ``system``'s parts (1 if undeclared).

    A part declares it as ``register(..., results_revision=n)``, or its module (the one
    that defines its ``make``) as ``RESULTS_REVISION = n`` for every part it registers.
    Raise it by one with a fix that changes the part's results: :func:`config_hash` then
    gives its trials new hashes, and their stored rows stop matching.

    Raises
    ------
    ValueError
        If a revision is not an integer >= 1 (the message names the part).
    """
    out = {}
    for role, part in system.parts().items():
        module = sys.modules.get(part.make.__module__)
        n = (part.results_revision if part.results_revision is not None
             else getattr(module, "RESULTS_REVISION", 1))
        if type(n) is not int or n < 1:
            raise ValueError(f"system.{role}: {part.name} declares results revision {n!r}; "
                             f"expected an integer >= 1")
        out[f"{role}.{part.name}"] = n
    return out


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def controller_name(kind: str, options: Mapping[str, Any] | None = None) -> str:
    """Canonical text of a method: ``controller`` or ``controller(key=value,...)``.

    The keys are the options the method sets and the parts other than the controller
    (``estimator=...``) it names. This is the ``controller`` column of results.csv and
    what the config hash covers; a method without options hashes as its controller alone.
    """
    if not options:
        return kind
    return f"{kind}({','.join(f'{k}={options[k]}' for k in sorted(options))})"


def method_system(controller: str) -> dict[str, Any]:
    """The ``Scenario.with_system`` changes of a method text (:func:`controller_name`).

    Values come back as text, so options are converted by their specs (``SystemConfig``
    checks them); ``rho_max=2.5`` becomes 2.5.
    """
    kind, _, rest = controller.partition("(")
    items = dict(item.split("=", 1) for item in rest.rstrip(")").split(",")) if rest else {}
    changes: dict[str, Any] = {"controller": kind}
    options: dict[str, Any] = {}
    for k, v in items.items():
        if k in ROLES:
            changes[k] = v
        else:
            options[k] = _option_value(v)
    changes["options"] = options
    return changes


def _option_value(text: str) -> Any:
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    return {"True": True, "False": False}.get(text, text)
