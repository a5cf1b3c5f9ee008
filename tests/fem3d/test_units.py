"""``[units]`` of a finite-element scene: the names of its consistent units, carried by the
figures' axes and titles (the numbers are the scene's own, never converted)."""

import pytest

from fem3d.kind import KIND, units_of
from tests.helpers import load_case
from thinfilm.scene import SceneError


def test_a_case_names_its_units_and_the_run_records_them():
    scene = load_case("lpanel")
    assert scene.units == ("mm", "N")
    p = KIND.parameters(scene)
    assert units_of(p) == ("mm", "N")
    labels = KIND.figure_labels(p)
    assert labels["u"] == "displacement u (mm)" and labels["energy"] == "energy (N mm)"
    assert KIND.figure_length_unit(p) == "mm"
    assert "E = 25850 N/mm$^2$" in KIND.title(p) and "Gc = 0.095 N/mm" in KIND.title(p)


def test_without_units_the_figures_say_none():
    scene = load_case("double_torsion_nondim")
    assert scene.units is None
    p = KIND.parameters(scene)
    assert units_of(p) == ("", "") and KIND.figure_labels(p) == KIND.labels and KIND.figure_length_unit(p) == ""


@pytest.mark.parametrize("value, message", [
    ({"length": "mm"}, "units.force: missing (required)"),
    ({"length": "", "force": "N"}, 'units.length = "": must be the name of a unit'),
    ({"length": "mm", "force": 1.0}, "units.force = 1.0: must be the name of a unit"),
    ({"length": "mm", "force": "N", "stress": "MPa"}, "units.stress: unknown key"),
])
def test_bad_units_are_refused(value, message):
    with pytest.raises(SceneError, match=message.replace("(", "\\(").replace(")", "\\)").replace("$", "\\$")):
        load_case("lpanel", {"units": value})
