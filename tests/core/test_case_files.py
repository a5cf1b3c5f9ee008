"""The scene files in ``cases/``: each one the README names must load, and a case's finer
variant must be the same experiment, changed only where its comment says."""

import dataclasses
import tomllib

import pytest

from thinfilm.scene import SceneError, load_scene, parse_scene

from studies.branching import imperfect
from tests.helpers import CASES


@pytest.mark.parametrize("path", sorted(CASES.glob("*.toml")), ids=lambda p: p.name)
def test_case_file_is_a_valid_scene(path):
    # load_scene raises SceneError (one line naming the key) on anything it cannot run.
    text = path.read_text()
    coarse = tomllib.loads(text).get("solver", {}).get("coarse")
    if coarse is not None and not (path.parent / coarse).exists():
        # The full-resolution scenes start each step from the main job's results, which a
        # fresh checkout does not have: the scene names the missing run, and the rest of it
        # must be valid.
        with pytest.raises(SceneError, match="run that scene first") as refused:
            load_scene(path)
        assert refused.value.key == "solver.coarse"
        line = next(line for line in text.splitlines() if line.split("=")[0].strip() == "coarse")
        text = text.replace(line, "")
    parse_scene(text, source=str(path))


@pytest.mark.parametrize("name", ["G20", "G15", "G07"])
def test_fine_branching_scene_changes_only_the_grid_and_the_film(name):
    # indentation_branching_*_fine.toml: Fig. 2.14 at the dissertation's eta = 0.0033 on a
    # grid with eta = 10 dx and a 5% toughness scatter; bond, toughness, indenter, loads,
    # solver and snapshots are those of the coarse case.
    coarse = load_scene(CASES / f"indentation_branching_{name}.toml")
    fine = load_scene(CASES / f"indentation_branching_{name}_fine.toml")
    changed = {"eta", "toughness_noise", "toughness_noise_length", "toughness_noise_seed"}
    for field in dataclasses.fields(coarse.model):
        if field.name not in changed:
            assert getattr(fine.model, field.name) == getattr(coarse.model, field.name), field.name
    assert (fine.load, fine.solver, fine.snapshots) == (coarse.load, coarse.solver, coarse.snapshots)
    assert fine.model.eta == pytest.approx(0.01 / 3.0)
    dx = (fine.domain.x[1] - fine.domain.x[0]) / fine.domain.cells[0]
    assert fine.model.eta / dx == pytest.approx(10.0)
    assert fine.model.toughness_noise == 0.05 and fine.model.toughness_noise_length == fine.model.eta
    # The study's figures of these scenes (studies/branching/README.md) come from
    # `python -m studies.branching.imperfect --finer --seeds 1`, which builds them from the
    # coarse case file with overrides: it must build this very scene (all but the file it
    # was read from and the overrides' record).
    built = imperfect.scene(name, 0.05, 1, imperfect.FINER)
    assert built.source == coarse.source and built.text == coarse.text and built.overrides is not None
    assert dataclasses.replace(built, text=fine.text, source=fine.source, overrides=None) == fine


@pytest.mark.parametrize("name, changed_model", [
    ("lpanel", {"law", "at", "ft", "softening", "eps"}),
    ("three_point_bending_II", {"law", "at", "ft", "softening"}),
    ("nooru_mohamed_4b", {"law", "at", "ft", "softening", "split", "eps"}),
])
def test_a_cohesive_case_is_its_experiment_with_the_cohesive_law(name, changed_model):
    # cases/<name>_czm.toml: the same specimen, material and loads as the AT1 case, with the
    # cohesive law; what else differs (eps, the split, the load steps: every one takes its
    # own, to pass the cohesive peak) its comment says
    at1 = load_scene(CASES / f"{name}.toml")
    czm = load_scene(CASES / f"{name}_czm.toml")
    assert czm.model.law == "czm" and at1.model.law == "at1"
    for field in dataclasses.fields(at1.model):
        if field.name not in changed_model:
            assert getattr(czm.model, field.name) == getattr(at1.model, field.name), field.name
    assert czm.geometry == at1.geometry
    for key in ("fixed", "displacement", "traction", "force", "constant_displacement", "constant_traction",
                "constant_force"):
        assert getattr(czm.load, key) == getattr(at1.load, key), key
    assert czm.load != at1.load      # the load steps
