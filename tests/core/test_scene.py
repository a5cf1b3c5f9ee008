"""The ``[solver]`` table and overrides: every engine option is declared once, settable from a
scene, checked with a one-line message naming its key, and the same whoever makes it."""

from __future__ import annotations

import dataclasses

import pytest

from tests.helpers import CASES, load_case
from thinfilm.engine import AltMinOptions, BacktrackOptions, Engine, SearchOptions, StabilityOptions
from thinfilm.options import OptionError
from thinfilm.scene import SceneError, apply_overrides, solver_keys


def other_value(f):
    """A valid value of option field ``f`` other than its default."""
    rule, default = f.metadata["rule"], f.default
    if rule.type == "boolean":
        return not default
    if rule.type == "choice":
        return next(c for c in rule.choices if c != default)
    if rule.type == "integer":
        return int(rule.minimum or 0) + 1 if isinstance(default, str) else default + 1  # "auto" -> a number
    if rule.maximum is not None:
        return 0.5 * (default + (rule.minimum or 0.0)) if default > (rule.minimum or 0.0) else 0.5 * rule.maximum
    return 2.0 * default if default > 0 else 1e-3


def bad_value(f):
    """A value of option field ``f`` outside its range (or of the wrong type)."""
    rule = f.metadata["rule"]
    if rule.type == "boolean":
        return 1
    if rule.type == "choice":
        return 7 if isinstance(rule.choices[0], int) else "bogus"
    if rule.type == "integer":
        return (rule.minimum or 0) - 1
    return (rule.minimum if rule.minimum is not None else 0.0) - 1.0


KEYS = sorted(solver_keys())


def test_every_engine_option_has_a_scene_key():
    fields = {(group, f.name) for group, f in solver_keys().values()}
    for group, cls in (("altmin", AltMinOptions), ("backtrack", BacktrackOptions), ("search", SearchOptions),
                       ("stability", StabilityOptions)):
        for f in dataclasses.fields(cls):
            assert (group, f.name) in fields, f"{cls.__name__}.{f.name} cannot be set from a scene"


@pytest.mark.parametrize("key", KEYS)
def test_each_solver_key_reaches_its_option(key):
    group, f = solver_keys()[key]
    value = other_value(f)
    overrides = {f"solver.{key}": value}
    if key == "u_rtol_min":
        overrides["solver.u_rtol_max"] = 1.0  # keep min <= max
    scene = load_case("fig2_5", overrides)
    target = scene.solver if group is None else getattr(scene.solver, group)
    assert getattr(target, f.name) == value
    assert value != f.default


@pytest.mark.parametrize("key", KEYS)
def test_each_solver_key_refuses_a_bad_value_naming_it(key):
    _, f = solver_keys()[key]
    value = bad_value(f)
    with pytest.raises(SceneError) as err:
        load_case("fig2_5", {f"solver.{key}": value})
    assert err.value.key == f"solver.{key}" and "\n" not in str(err.value)
    assert str(err.value).startswith(f"{CASES / 'fig2_5.toml'}: solver.{key} = ")


def test_options_check_themselves_whoever_makes_them():
    # The same checks for a scene and for a script: the dataclass refuses, the engine need not.
    with pytest.raises(OptionError, match=r"omega = 100: must be in \[1, 64\]"):
        AltMinOptions(omega=100)
    with pytest.raises(OptionError, match="u_rtol_min = 0.1: must be <= u_rtol_max"):
        AltMinOptions(u_rtol_min=0.1)
    with pytest.raises(OptionError, match="direction = 2: must be 1 .oldest first. or -1"):
        BacktrackOptions(direction=2)
    # One default each (the scene's and the dataclass's are the same object's).
    scene = load_case("fig2_15")  # no [solver] table at all: not an engine scene
    assert not hasattr(scene, "solver")
    assert load_case("indentation").solver.altmin.omega == AltMinOptions().omega == 4.0


def test_backtracking_needs_a_proportional_load():
    with pytest.raises(SceneError, match='solver.backtrack = "standard": backtracking needs a load proportional to t;'
                                         ' load.kind = "indenter" is not'):
        load_case("indentation", {"solver.backtrack": "standard"})


def test_search_delta_is_relative_to_the_toughness():
    # The threshold the engine applies is delta * toughness: the same 5e-5 for Fig. 2.5's film
    # (G/a = 0.05) that its scene gave absolutely before the option was declared relative.
    scene = load_case("fig2_5")
    assert scene.solver.search.delta == 1e-3 and scene.model.toughness == 0.05

    class Film:
        n_alpha, proportional, toughness = 1, True, scene.model.toughness

        def trial_states(self, u, alpha, t):
            return []

    engine = Engine.from_options(Film(), scene.solver)
    assert engine.search.delta * engine.model.toughness == pytest.approx(5e-5, rel=1e-15)


def test_overrides_set_make_and_remove_keys():
    data = {"model": {"eta_dx": 10, "lam": 10.0}}
    apply_overrides(data, {"model.eta_dx": None, "model.eta": 0.01, "solver.tol": 1e-3})
    assert data == {"model": {"lam": 10.0, "eta": 0.01}, "solver": {"tol": 1e-3}}
    with pytest.raises(SceneError, match="model.lam: is a value, not a table"):
        apply_overrides(data, {"model.lam.x": 1})
    scene = load_case("fig2_7", {"model.eta_dx": None, "model.eta": 0.01, "domain.cells": [30, 6]})
    assert scene.model.eta == 0.01 and scene.domain.cells == (30, 6)
    assert scene.overrides == '{"domain.cells": [30, 6], "model.eta": 0.01, "model.eta_dx": null}'
