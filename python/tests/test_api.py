"""The `sigmaheart` Python module (python/, docs/python.md): configs, a simulator on a parameter
vector, a study in-process, results into numpy, and errors as exceptions with the command line's
file:line:column message. Fast tier: one lumped-sphere beat per run, an Ishigami study of 256
points."""
import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import sigmaheart as sh

SOURCE = os.environ.get("SIGMAHEART_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))


@pytest.fixture()
def workdir(tmp_path, monkeypatch):
    os.symlink(os.path.join(SOURCE, "configs"), tmp_path / "configs")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_a_beat_comes_back_as_numpy_curves_and_indices_with_units(workdir):
    cfg = sh.load_config("configs/healthy.yaml")
    assert cfg.model == "lumped-sphere"
    names = [p["name"] for p in cfg.parameters]
    assert "sigma0" in names and cfg.parameters[names.index("sigma0")]["unit"] == "Pa"
    beat = cfg.run()
    t, v = beat["times"], beat["curves"]["V_lv"]
    assert isinstance(t, np.ndarray) and t.shape == v.shape and np.all(np.diff(t) > 0)
    assert beat["units"]["V_lv"] == "m^3" and beat["units"]["P_lv"] == "Pa"
    # The indices are computed from these curves: EDV is the largest volume, in the same unit.
    assert beat["indices"]["EDV"] == pytest.approx(v.max(), rel=1e-12)
    assert beat["index_units"]["EDV"] == "m^3" and 0.3 < beat["indices"]["EF"] < 0.8
    assert beat["period"] == pytest.approx(t[-1] - t[0], rel=1e-12)
    # The same run with a parameter changed by name, and as a full vector: the same bits.
    theta = beat["theta"].copy()
    theta[names.index("sigma0")] *= 1.2
    stronger = cfg.run({"sigma0": theta[names.index("sigma0")]})
    assert stronger["indices"]["EF"] > beat["indices"]["EF"]
    np.testing.assert_array_equal(cfg.run(theta)["curves"]["V_lv"], stronger["curves"]["V_lv"])


def test_bad_input_raises_input_error_with_file_line_and_column(workdir):
    (workdir / "bad.yaml").write_text("name: bad\nsimulator:\n  model: lumped-sphere\n  numerics: {dtt: 1.0e-3}\n")
    with pytest.raises(sh.InputError) as e:
        sh.load_config("bad.yaml")
    assert re.search(r"bad\.yaml:4:\d+: .*dtt", str(e.value)), str(e.value)
    cfg = sh.load_config("configs/healthy.yaml")
    with pytest.raises(sh.InputError, match="sigma0"):
        cfg.run({"sigma0": -1.0})
    with pytest.raises(sh.InputError, match="unknown parameter|did you mean"):
        cfg.run({"sigma00": 1.0})
    # The commands: an override is located at its --set, a config error at file:line:column.
    with pytest.raises(sh.InputError, match=r"--set sensitivity\.method=sobl: .*did you mean 'sobol'"):
        sh.sensitivity("configs/sensitivity-ishigami.yaml", overrides=["sensitivity.method=sobl"],
                       output="results/x.h5")
    with pytest.raises(sh.InputError, match=r"bad\.yaml:4:\d+: .*dtt"):
        sh.calibrate("bad.yaml", output="results/y.h5")
    assert not os.path.exists("results/x.h5") and not os.path.exists("results/y.h5")


def test_a_failed_run_raises_run_failed(workdir):
    cfg = sh.load_config("configs/healthy.yaml",
                         overrides=["numerics.max_beats=3", "numerics.periodic_tolerance=1e-12"])
    with pytest.raises(sh.RunFailed, match="not-periodic|periodic"):
        cfg.run()


def test_a_study_runs_in_process_and_its_results_read_into_numpy(workdir):
    path = sh.sensitivity("configs/sensitivity-ishigami.yaml", output="results/ishigami.h5",
                          overrides=["sensitivity.sobol.N=256", "sensitivity.sobol.bootstrap=50",
                                     "sensitivity.sobol.convergence_levels=1"])
    assert os.path.exists(path)
    res = sh.read_results(path)
    found = {}

    def walk(group, prefix):
        for key, value in group.items():
            if isinstance(value, dict):
                walk(value, prefix + "/" + key)
            elif isinstance(value, np.ndarray):
                found[prefix + "/" + key] = value
    walk(res, "")
    s1 = [k for k in found if k.endswith("/S1")]
    assert s1, sorted(found)
    # Ishigami (a = 7, b = 0.1): exact S1 = 0.3139, 0.4424, 0 (Saltelli et al. 2008, s.4.2), each
    # within the study's own bootstrap half-width (S1_conf, 95 %) of its estimate.
    estimate = np.ravel(found[s1[0]])[:3]
    half_width = np.ravel(found[s1[0] + "_conf"])[:3]
    assert np.all(np.abs(estimate - [0.3139, 0.4424, 0.0]) <= half_width), (estimate, half_width)


def test_the_readme_example_runs(workdir):
    text = open(os.path.join(SOURCE, "README.md")).read()
    block = text.split("<!-- python-example -->", 1)[1].split("```python", 1)[1].split("```", 1)[0]
    assert len(block.strip().splitlines()) <= 12
    os.makedirs("results", exist_ok=True)
    exec(compile(block, "README.md", "exec"), {})


def test_a_calibration_in_process_gives_the_command_lines_numbers(workdir):
    # sigma0 of the bundled volunteer from its curves (converges in 3 UT iterations, 9 beats): the module
    # runs the command in this process, so its summary equals the executable's bit for bit.
    (workdir / "cal.yaml").write_text(
        "name: cal\nseed: 1\nsimulator:\n  model: lumped-sphere\n  numerics: {dt: 1.0e-3, max_beats: 400}\n"
        "observations:\n  file: configs/data/volunteer02.csv\n  curves: [V_lv, P_lv]\n"
        "  noise: {V_lv: 2 mL, P_lv: 1.5 mmHg}\n"
        "estimate:\n  sigma0: {spread: 30 %, transform: log}\n"
        "calibration: {sigma_points: simplex, mode: map, max_iterations: 3, tolerance: 1.0e-2}\n")
    path = sh.calibrate("cal.yaml", output="results/cal.h5", summary="results/cal.json")
    assert os.path.exists(path)
    ours = json.load(open("results/cal.json"))
    binary = os.environ.get("SIGMAHEART_BINARY")
    if binary is None:
        pytest.skip("SIGMAHEART_BINARY not set (CTest sets it)")
    subprocess.run([binary, "--log-level", "off", "calibrate", "cal.yaml", "-o", "results/cli.h5",
                    "--summary", "results/cli.json"], check=True)
    cli = json.load(open("results/cli.json"))
    assert ours["parameters"] == cli["parameters"] and ours["objective"] == cli["objective"]
    assert ours["simulations"] == cli["simulations"] > 0
    # The fit moved sigma0 and lowered the misfit against the curves.
    assert ours["status"] == "converged" and ours["objective"] < ours["objective_prior"]
    assert ours["parameters"]["sigma0"]["value"] > 0.0
