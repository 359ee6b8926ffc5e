"""pytest suite of the Python module `vlt` (python/vlt_module.cc, docs/python.md), run by CTest
(`python_module`) with PYTHONPATH=<build>/python. References: the `vlt` command's own files for the
same job (points.jsonl, points.csv), the module's two entry points against each other, and closed
forms (U = k sqrt(diag covariance), symmetric covariances)."""
import json
import math
import os
import subprocess
import tempfile

import numpy as np
import pytest

import vlt

SOURCE = os.environ["VLT_SOURCE_DIR"]
VLT = os.environ["VLT_BINARY"]
JOB = os.path.join(SOURCE, "examples", "panel_station.toml")


def test_models_list_the_generated_models_with_units():
    models = {m["name"]: m for m in vlt.models()}
    assert {"mirror", "head", "gum_h1_end_gauge"} <= set(models)
    mirror = models["mirror"]
    assert mirror["kind"] == "tracker"
    assert [r["name"] for r in mirror["readings"]] == ["range", "azimuth", "elevation"]
    assert len(mirror["params"]) == 20
    assert all(p["default_u"] > 0 and p["unit"] for p in mirror["params"])


def test_run_equals_the_command_line():
    r = vlt.run(JOB, monte_carlo=False)
    assert r["schema"] == "vlt-results/2"
    n = r["job"]["points"]
    assert len(r["points"]) == n == len(r["names"])
    assert r["estimate"].shape == (n, 3) and r["covariance"].shape == (n, 3, 3) and r["U"].shape == (n, 3)
    # The command line, same job, GUM only: the same points.jsonl objects, bit for bit.
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([VLT, "-q", "run", JOB, "--no-mcm", "-o", out], check=True)
        with open(os.path.join(out, "points.jsonl")) as f:
            cli = [json.loads(line) for line in f]
    assert [p["gum"] for p in r["points"]] == [p["gum"] for p in cli]
    # The arrays are the same numbers as the dicts; U = k sqrt(diag); covariances symmetric.
    for i, p in enumerate(r["points"]):
        assert r["names"][i] == p["name"]
        assert np.array_equal(r["estimate"][i], p["gum"]["estimate"])
        assert np.array_equal(r["covariance"][i], np.array(p["gum"]["covariance"]))
    k = r["job"]["k_axis"]
    assert np.allclose(r["U"], k * np.sqrt(np.einsum("nii->ni", r["covariance"])), rtol=1e-14, atol=0)
    assert np.array_equal(r["covariance"], np.transpose(r["covariance"], (0, 2, 1)))


def test_gum_of_an_array_of_readings_equals_run():
    r = vlt.run(JOB, monte_carlo=False)
    readings = np.array([[p["readings"]["range"], p["readings"]["azimuth"], p["readings"]["elevation"]]
                         for p in r["points"]])
    g = vlt.gum(JOB, readings)
    assert np.array_equal(g["estimate"], r["estimate"])
    assert np.array_equal(g["covariance"], r["covariance"])
    assert np.array_equal(g["U"], r["U"])
    # Thread count does not change a bit; a wrong shape is a ValueError.
    assert np.array_equal(vlt.gum(JOB, readings, threads=1)["covariance"], vlt.gum(JOB, readings, threads=2)["covariance"])
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        vlt.gum(JOB, readings[:, :2])


def test_a_job_given_as_a_dict():
    job = {
        "job": {"name": "from-python"},
        "tracker": {"model": "mirror", "noise": {"range": "5 um + 0.5 um/m", "azimuth": "0.5 arcsec",
                                                  "elevation": "0.5 arcsec"}},
        "plan": {"point": [{"name": "A", "x": 3.0, "y": 0.0, "z": 0.0}, {"name": "B", "x": 4.0, "y": 1.0, "z": 0.5}]},
        "task": [{"kind": "distance", "name": "AB", "points": ["A", "B"]}],
        "monte_carlo": {"trials": 20000, "seed": 7},
    }
    r = vlt.run(job)
    assert r["job"]["name"] == "from-python" and r["names"] == ["A", "B"]
    task = r["tasks"][0]
    assert task["name"] == "AB" and task["quantities"][0] == "distance"
    assert task["gum"]["value"][0] == pytest.approx(math.sqrt(1 + 1 + 0.25), abs=1e-9)
    assert task["mcm"] is not None and r["monte_carlo"]["trials"] == 20000
    # The same job written as a file gives the same numbers.
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "job.toml")
        with open(path, "w") as f:
            f.write('[job]\nname = "from-python"\n[tracker]\nmodel = "mirror"\n[tracker.noise]\n'
                    'range = "5 um + 0.5 um/m"\nazimuth = "0.5 arcsec"\nelevation = "0.5 arcsec"\n'
                    '[[plan.point]]\nname = "A"\nx = 3.0\ny = 0.0\nz = 0.0\n'
                    '[[plan.point]]\nname = "B"\nx = 4.0\ny = 1.0\nz = 0.5\n'
                    '[[task]]\nkind = "distance"\nname = "AB"\npoints = ["A", "B"]\n'
                    '[monte_carlo]\ntrials = 20000\nseed = 7\n')
        from_file = vlt.run(path)
    assert np.array_equal(from_file["covariance"], r["covariance"])
    assert from_file["tasks"][0]["mcm"] == task["mcm"]


def test_bad_input_is_a_value_error_with_the_one_line_message():
    with pytest.raises(ValueError, match=r"^<dict>: tracker\.model: unknown model 'nope'"):
        vlt.run({"tracker": {"model": "nope"}, "plan": {"point": [{"name": "A", "x": 3, "y": 0, "z": 0}]}})
    with pytest.raises(ValueError, match="cannot read the job file"):
        vlt.run("/nonexistent/job.toml")


def test_numbers_past_the_command_lines_rules_are_value_errors():
    # As `--threads` and `--trials` refuse them (issue 32): threads=100000 once asked the system for
    # 10^5 threads and was killed.
    job = os.path.join(SOURCE, "examples", "alignment", "panel_alignment.toml")
    for kwargs, message in [({"threads": -3}, r"^run: threads: -3 is not an integer in 0 \.\. 1024"),
                            ({"threads": 100000}, r"^run: threads: 100000 is not an integer in 0 \.\. 1024"),
                            ({"trials": 10**12}, r"^run: trials: 1000000000000 is not an integer in 0 \.\. 1000000000")]:
        with pytest.raises(ValueError, match=message):
            vlt.run(job, **kwargs)
    with pytest.raises(ValueError, match=r"^network: threads: -1 is not"):
        vlt.network(os.path.join(SOURCE, "examples", "network", "drift_network.toml"), threads=-1)
    # Readings given to gum() pass the command line's rule (vlt/job.h CheckReadings): a 1e6 m range
    # and an azimuth of 1e20 rad were accepted before.
    for row, message in [([1e6, 0.1, 0.2], r"^gum: readings\[0\]: range \[m\]: 1e\+06 m is beyond any laser tracker"),
                         ([5.0, 1e20, 0.2], r"^gum: readings\[0\]: azimuth \[rad\]: .* is not a plausible angle"),
                         ([0.0, 0.1, 0.2], r"^gum: readings\[0\]: range must be positive"),
                         ([float("nan"), 0.1, 0.2], r"^gum: readings\[0\]: range \[m\]: not a finite number")]:
        with pytest.raises(ValueError, match=message):
            vlt.gum(JOB, np.array([row]))


def test_simulate_takes_the_command_lines_rules():
    with pytest.raises(ValueError, match=r"^simulate: points\[1\]: 1e\+06 m from the tracker is beyond any laser tracker"):
        vlt.simulate("mirror", np.array([[3.0, 0.0, 0.0], [1e6, 0.0, 0.0]]))
    with pytest.raises(ValueError, match=r"^simulate: params: tmv: beyond what vlt computes with"):
        vlt.simulate("mirror", np.array([[3.0, 0.0, 0.0]]), {"tmv": 1e300})


def test_arguments_of_the_wrong_type_are_a_one_line_type_error():
    # pybind11's own message lists the overloads over several lines (issue 32 item 5).
    for call in [lambda: vlt.gum(JOB, "not an array", threads="two"),
                 lambda: vlt.run(JOB, monte_carlo="yes please", trials=[1]),
                 lambda: vlt.network(42)]:
        with pytest.raises(TypeError) as e:
            call()
        text = str(e.value)
        assert "\n" not in text and "arguments of the wrong type" in text and "expected" in text, text


def test_simulate_equals_the_command_line():
    points = np.array([[4.0, 1.0, 0.5], [-3.0, 2.0, -0.4]])
    s = vlt.simulate("mirror", points, {"tmv": 5e-6, "rmv": 4.84813681109536e-06})
    assert s["readings"].shape == (2, 3) and s["reported"].shape == (2, 3)
    for i, p in enumerate(points):
        cli = json.loads(subprocess.run([VLT, "--json", "simulate", "--model", "mirror", "--point",
                                         ",".join(repr(v) for v in p), "tmv=5um", "rmv=1arcsec"],
                                        check=True, capture_output=True, text=True).stdout)
        assert np.allclose(s["readings"][i], [cli["readings"]["range_m"], cli["readings"]["azimuth_rad"],
                                              cli["readings"]["elevation_rad"]], rtol=0, atol=1e-15)
        assert np.allclose(s["reported"][i], cli["reported_m"], rtol=0, atol=1e-15)
    # No error state: the tracker reads the ideal readings and reports the true point.
    ideal = vlt.simulate("mirror", points)
    assert np.allclose(ideal["reported"], points, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="not a parameter"):
        vlt.simulate("mirror", points, {"nope": 1.0})


def test_a_custom_model_job_equals_the_command_line():
    # GUM H.2 (examples/custom): a custom-model job ([model]) with Type A observations from a CSV
    # next to the job file; the module reads it as the command line does.
    job = os.path.join(SOURCE, "examples", "custom", "gum_h2_impedance.toml")
    r = vlt.run(job, trials=20000, seed=4)
    assert r["schema"] == "vlt-custom-results/1"
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([VLT, "-q", "run", job, "--trials", "20000", "--seed", "4", "-o", out], check=True)
        with open(os.path.join(out, "results.json")) as f:
            cli = json.load(f)
    assert r["outputs"] == cli["outputs"]
    assert r["input_correlations"] == cli["input_correlations"]
    # The published GUM H.2 result: R = 127.732 ohm, u(R) = 0.071 ohm.
    R = [o for o in r["outputs"] if o["name"] == "R"][0]
    assert abs(R["gum"]["estimate"] - 127.732) < 0.0005 and abs(R["gum"]["u"] - 0.071) < 0.0005


def _without_run_stamps(results):
    """results.json minus what differs between two runs of the same input (when, which build)."""
    return {k: v for k, v in results.items() if k not in ("created", "vlt_commit", "files")}


def test_network_equals_the_command_line():
    plan = os.path.join(SOURCE, "examples", "network", "scale_bar_network.toml")
    r = vlt.network(plan)
    assert r["schema"] == "vlt-network/1"
    assert [d["name"] for d in r["distances"]] == ["SB1", "SB2", "SB3"]
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([VLT, "-q", "network", plan, "-o", out], check=True)
        with open(os.path.join(out, "results.json")) as f:
            cli = json.load(f)
    assert _without_run_stamps(r) == _without_run_stamps(cli)
    # robust=False: the same plan (nothing to remove) without the robust section.
    off = vlt.network(plan, robust=False)
    assert "robust" not in off and off["targets"] == r["targets"]


def test_calibrate_equals_the_command_line_and_says_whether_it_fits(monkeypatch):
    # One creation time for both runs (SOURCE_DATE_EPOCH, read by the module and the command): the
    # file's content_sha256 covers its "created" line, and two runs a second apart under load gave
    # two hashes (the test failed now and then).
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1795000000")
    job = os.path.join(SOURCE, "examples", "calibration", "simulated_calibration.toml")
    c = vlt.calibrate(job)
    assert c["results"]["fit"]["observations"] > 0 and c["results"]["fit"]["fits"] is True
    assert "fits = true" in c["calibration_toml"]
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([VLT, "-q", "calibrate", job, "-o", out], check=True)
        with open(os.path.join(out, "calibration.toml")) as f:
            cli = f.read()
    assert c["calibration_toml"] == cli
    unfit = vlt.calibrate(os.path.join(SOURCE, "tests", "cli", "calibration", "mirror_on_head.toml"))
    assert "fits = false" in unfit["calibration_toml"] and unfit["results"]["fit"]["fits"] is False
    assert unfit["results"]["fit"]["fit_problem"].startswith("the data do not fit the model")


def test_plan_equals_the_command_line():
    job = os.path.join(SOURCE, "examples", "station_plan.toml")
    p = vlt.plan(job, threads=2)
    assert p["plan"]["recommended"]["feasible"] is True
    assert "[station]" in p["planned_job_toml"]
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([VLT, "-q", "plan", job, "--threads", "2", "-o", out], check=True)
        with open(os.path.join(out, "plan.json")) as f:
            cli = json.load(f)
        with open(os.path.join(out, "planned_job.toml")) as f:
            cli_job = f.read()
    # The same search (seeded): the same station, objective and map; only the run's own time differs.
    for key in ("recommended", "job_station", "map"):
        assert p["plan"][key] == cli[key], key
    assert p["plan"]["search"]["evaluations"] == cli["search"]["evaluations"]
    assert p["planned_job_toml"] == cli_job
    with pytest.raises(ValueError, match="optimize: the job has no \\[optimize\\] section"):
        vlt.plan(os.path.join(SOURCE, "examples", "b89_length.toml"))


def test_alignment_and_deviations_equal_the_command_line():
    # examples/alignment (docs/tasks.md "Alignment to nominal"): the alignments and deviations are
    # tasks; the module returns the command line's results.json tasks, nominal geometry included.
    job = os.path.join(SOURCE, "examples", "alignment", "panel_alignment.toml")
    r = vlt.run(job, monte_carlo=False)
    tasks = {t["name"]: t for t in r["tasks"]}
    assert tasks["to_cad"]["kind"] == "best_fit" and tasks["jig_321"]["kind"] == "rps"
    assert tasks["to_cad"]["weighting"] == "none" and tasks["to_cad_gls"]["weighting"] == "covariance"
    assert tasks["holes_gls.T1"]["weighting"] == "covariance" and tasks["to_cad_gls"]["weighted_fit"]["degrees_of_freedom"] == 6
    assert tasks["to_cad"]["units"] == ["m", "m", "m", "rad", "rad", "rad", "m"]
    s17 = tasks["skin.S17"]
    assert s17["kind"] == "deviation" and s17["nominal"]["point"] == "S17" and s17["nominal"]["alignment"] == "to_cad"
    assert abs(np.linalg.norm(s17["nominal"]["normal"]) - 1.0) < 1e-12
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([VLT, "-q", "run", job, "--no-mcm", "-o", out], check=True)
        with open(os.path.join(out, "results.json")) as f:
            cli = {t["name"]: t for t in json.load(f)["tasks"]}
    assert set(cli) == set(tasks)
    for name, t in tasks.items():
        assert t["gum"] == cli[name]["gum"], name


def test_a_model_built_from_its_spec_is_used_by_name(tmp_path, monkeypatch):
    # vlt.models.build is `vlt model build` (issue 31): a spec not compiled into vlt, into a fresh
    # cache, then a job naming it. JCGM 101 9.4 at x1 = 0.010: the GUM's first order y = u = 1e-4.
    monkeypatch.setenv("VLT_MODEL_CACHE", str(tmp_path / "cache"))
    spec = os.path.join(SOURCE, "tests", "models", "jcgm101_comparison_loss.toml")
    b = vlt.models.build(spec)
    assert b["name"] == "jcgm101_comparison_loss" and not b["cached"]
    assert vlt.build_model(spec)["cached"]
    assert any(m["name"] == "jcgm101_comparison_loss" and m["built"] for m in vlt.models())
    r = vlt.run({"model": {"name": "jcgm101_comparison_loss"}}, monte_carlo=False)
    assert abs(r["outputs"][0]["gum"]["estimate"] - 1e-4) < 1e-15 and abs(r["outputs"][0]["gum"]["u"] - 1e-4) < 1e-15
    # Rebuilt in the same process with another expression: the new model runs (a new library file;
    # dlopen of the old path would have returned the old model).
    changed = tmp_path / "jcgm101_comparison_loss.toml"
    changed.write_text(open(spec).read().replace('expression = "x1^2 + x2^2"', 'expression = "x1^2 + x2^2 + 1"'))
    assert not vlt.models.build(str(changed))["cached"]
    r = vlt.run({"model": {"name": "jcgm101_comparison_loss"}}, monte_carlo=False)
    assert abs(r["outputs"][0]["gum"]["estimate"] - (1 + 1e-4)) < 1e-12
