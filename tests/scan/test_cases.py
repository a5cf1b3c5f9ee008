"""The case scans, row by row against what is known of each: a closed form, a scaling law,
an exact self-similarity."""

import math

import numpy as np
import pytest

from onedim.fragment import scaling_F
from thinfilm.scan.execute import execute
from thinfilm.scan.metrics import RunFiles
from thinfilm.scan.plan import load_plan
from thinfilm.scan.table import read_table, run_dir
from tests.helpers import CASES


def test_exact_film_first_crack_against_the_closed_form(exact1d_scan):
    plan, out, rows, counts = exact1d_scan
    assert counts == {"done": 14}
    for row in rows:
        lam, toughness = float(row["model.lam"]), float(row["model.toughness"])
        centred = math.sqrt(2.0 * toughness / (scaling_F(1.0, lam) - 2.0 * scaling_F(0.5, lam)))
        first = RunFiles(run_dir(out, row["run"])).events[0]
        t = float(row["first_event_t"])
        if lam <= 7.0:
            # a film short against its decay length breaks at its middle, at the closed form's load
            assert row["first_event_cracks"] == "1.0" and first["cracks"] == pytest.approx([0.0], abs=1e-9)
            assert t == pytest.approx(centred, rel=1e-9)
        else:
            # lam = 8: one crack off the middle beats the centred one, at a lower load
            assert row["first_event_cracks"] == "1.0" and abs(first["cracks"][0]) > 0.03
            assert t < centred * (1 - 1e-4)


def test_cantilever_crack_spacing_scales_with_the_decay_length(spacing_scan):
    plan, out, rows, counts = spacing_scan
    assert counts == {"done": 5}
    winkler = np.array([float(r["model.winkler"]) for r in rows])
    spacing = np.array([float(r["crack_spacing_at_t_max"]) for r in rows])
    decay = (4.0 / winkler) ** 0.25                      # 1/lam, winkler = 4 lam^4
    assert np.all(np.diff(spacing) < 0) and all(float(r["cracks_at_t_max"]) >= 6 for r in rows)
    # about three decay lengths (docs/scans.md#crack-spacing-of-the-coated-cantilever)
    assert np.all((spacing / decay > 2.6) & (spacing / decay < 3.1))
    slope = np.polyfit(np.log(decay), np.log(spacing), 1)[0]
    assert 0.8 < slope < 1.0


def test_lpanel_toughness_scan_is_self_similar(client, tmp_path):
    # Gc -> k Gc with the load -> sqrt(k) load: energies x k, forces x sqrt(k), the same damage
    plan = load_plan(CASES / "scans" / "lpanel_toughness.toml")
    table, figure, counts = execute(plan, tmp_path, client=client)
    rows = read_table(table)
    assert counts == {"done": 4} and figure.exists()
    k = np.array([float(r["model.Gc"]) for r in rows]) / 0.095
    for name, power in [("first_event_t", 0.5), ("peak_force", 0.5), ("t_at_peak_force", 0.5),
                        ("total_at_t_max", 1.0), ("crack_length_at_t_max", 0.0), ("iterations", 0.0)]:
        scaled = np.array([float(r[name]) for r in rows]) / k ** power
        assert scaled == pytest.approx(np.full(4, scaled[1]), rel=1e-7), name
    assert float(rows[1]["crack_length_at_t_max"]) > 100.0        # a crack did run


def test_repeats_over_a_seed_are_rows_of_their_own(client, tmp_path):
    # An imperfect film (5% ... 20% toughness scatter, a seed per draw): each seed its own run,
    # and the first crack moves with the draw.
    scan = tmp_path / "scan.toml"
    scan.write_text(f'base = "{CASES / "fig2_5.toml"}"\n[vary]\n"model.toughness_noise" = [0.05, 0.2]\n'
                    '[set]\n"domain.cells" = 160\n"model.eta_dx" = 8\n"load.steps" = 30\n"solver.search" = false\n'
                    '"model.toughness_noise_length" = 0.02\n'
                    '[repeat]\nkey = "model.toughness_noise_seed"\ncount = 3\nfirst = 1\n'
                    '[collect]\nmetrics = ["first_event_t", "cracks_at_t_max"]\n')
    table, figure, counts = execute(load_plan(scan), tmp_path / "out", client=client)
    rows = read_table(table)
    assert counts == {"done": 6} and figure.exists()
    assert [r["model.toughness_noise_seed"] for r in rows] == ["1", "2", "3"] * 2
    positions = [tuple(RunFiles(run_dir(tmp_path / "out", r["run"])).events[0]["cracks"]) for r in rows]
    assert len(set(positions[3:])) > 1         # 20% scatter: the first crack moves with the draw


def test_every_metric_of_a_film_run_reads_its_files(spacing_scan):
    import h5py

    from thinfilm.scan.metrics import METRICS, compute

    plan, out, rows, _ = spacing_scan
    rundir = run_dir(out, rows[0]["run"])
    names = [m.name for m in METRICS.values() if m.kinds is None or "plate" in m.kinds]
    got = compute(rundir, names)
    summary = RunFiles(rundir).summary
    with h5py.File(rundir / "results.h5", "r") as f:
        steps = {k: v[()] for k, v in f["steps"].items()}
    assert got["t_max"] == 2.4 and got["first_event_t"] == summary["events"][0]["t"]
    assert got["events"] == len(summary["events"]) and got["cracks_at_t_max"] == len(summary["events"][-1]["cracks"])
    assert got["total_at_t_max"] == steps["total"][-1] == pytest.approx(got["elastic_at_t_max"] + got["surface_at_t_max"])
    assert got["surface_at_t_max"] == pytest.approx(got["cracks_at_t_max"] * 1.0, rel=0.1)   # G/a = 1 per crack
    assert got["iterations"] == steps["iterations"].sum() and got["steps_s"] == steps["time_total"].sum() > 0
    assert 0 < got["wall_s"] and math.isnan(compute(rundir / "missing", ["first_event_t"])["first_event_t"])


def test_compliance_is_the_last_displacement_over_the_last_force(tmp_path):
    import json

    from thinfilm.scan.metrics import compute

    steps = {"t": [0.0, 0.05, 0.1], "displacement": [0.0, 0.05, 0.1], "force": [0.0, 40.0, 80.0]}
    (tmp_path / "summary.json").write_text(json.dumps({"events": [], "steps": steps}))
    assert compute(tmp_path, ["compliance"])["compliance"] == 0.1 / 80.0
    steps["force"][-1] = 0.0             # no force: no compliance, not an error
    (tmp_path / "summary.json").write_text(json.dumps({"events": [], "steps": steps}))
    assert math.isnan(compute(tmp_path, ["compliance"])["compliance"])
