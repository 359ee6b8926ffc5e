#!/usr/bin/env python3
"""Round trip of a profile (docs/profiles.md): `vlt prior PROFILE` writes prior.toml; a `vlt test`
file with the profile's tracker, layout and MPEs loads that prior as its calibration; vlt test's own
propagation (an independent code path: SimulateTests + the calibration file's reader) must give
every length and ranging test the same u(params) as vlt prior's tests.csv, and every test with an
MPE must meet it: z * sqrt(u_params^2 + u_noise^2) <= MPE. Then a measurement job runs with the
prior (`vlt run --calibration`).

usage: check_prior_roundtrip.py VLT PROFILE OUT_DIR RUN_JOB
"""
import csv
import math
import os
import shutil
import subprocess
import sys
import tomllib


def run(args):
    done = subprocess.run(args, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(args)}: exit {done.returncode}\n{done.stderr}")
    return done.stdout


def main():
    vlt, profile, out, run_job = sys.argv[1:5]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    run([vlt, "prior", profile, "-o", f"{out}/prior"])
    with open(profile, "rb") as f:
        spec = tomllib.load(f)
    noise = spec["tracker"]["noise"]
    layout = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(profile)), spec["tests"]["layout"]))
    mpe = ", ".join(f'{k} = "{v}"' for k, v in spec["tests"]["mpe"].items())
    p = spec.get("prior", {}).get("conformance_probability", 0.95)
    test_file = f"{out}/roundtrip_tests.toml"
    with open(test_file, "w") as f:
        f.write(f'[job]\nname = "roundtrip"\n\n[tracker]\nmodel = "{spec["tracker"]["model"]}"\n'
                f'calibration = "prior/prior.toml"\n\n[tracker.noise]\n')
        for k, v in noise.items():
            f.write(f'{k} = "{v}"\n')
        f.write(f'\n[tests]\nlayout = "{layout}"\nmpe = {{ {mpe} }}\ncoverage_probability = {p}\n')
    run([vlt, "test", test_file, "-o", f"{out}/test"])
    with open(f"{out}/prior/tests.csv") as f:
        prior = {r["test"]: r for r in csv.DictReader(f)}
    with open(f"{out}/test/tests.csv") as f:
        tested = {r["test"]: r for r in csv.DictReader(f)}
    z = float(json_z(f"{out}/prior/results.json"))
    compared = 0
    for name, r in prior.items():
        u_p, u_n, mpe_m = float(r["u_parameters_m"]), float(r["u_noise_m"]), float(r["mpe_m"])
        if float(r["conformance_probability"]) < p - 1e-9:
            sys.exit(f"{name}: conformance {r['conformance_probability']} below the stated {p}")
        if r["kind"] == "two_face":
            # |Delta| of a Gaussian vector: its conformance is checked by Monte Carlo in
            # tests/test_prior.cc; vlt test's u(params) is along one direction, not the trace.
            continue
        # A scalar normal error: P(|E| <= MPE) >= p is z u <= MPE.
        if z * math.hypot(u_p, u_n) > mpe_m * (1 + 1e-9):
            sys.exit(f"{name}: z u = {z * math.hypot(u_p, u_n)} m exceeds the MPE {mpe_m} m")
        if abs(math.erf(mpe_m / (math.hypot(u_p, u_n) * math.sqrt(2))) - float(r["conformance_probability"])) > 1e-12:
            sys.exit(f"{name}: conformance {r['conformance_probability']} is not 2 Phi(MPE/u) - 1")
        t = tested[name]
        if abs(float(t["u_parameters_m"]) - u_p) > 1e-9 * u_p:
            sys.exit(f"{name}: vlt test u(params) {t['u_parameters_m']} != vlt prior {u_p}")
        if abs(float(t["mpe_m"]) - mpe_m) > 1e-12:
            sys.exit(f"{name}: MPE {t['mpe_m']} != {mpe_m}")
        compared += 1
    if compared == 0:
        sys.exit("no length or ranging test compared")
    summary = run([vlt, "run", run_job, "--calibration", f"{out}/prior/prior.toml", "-o", f"{out}/run"])
    if "a prior from the datasheet's MPE" not in summary:
        sys.exit("the run's summary does not say its parameters are a prior from a datasheet")
    if spec["tracker"]["model"] == "head":
        calibrate_with_prior(vlt, out)
    print(f"ok: {compared} length/ranging tests agree with vlt test, all {len(prior)} meet their MPE at p = {p}; the job ran")


def calibrate_with_prior(vlt, out):
    """A profile as the prior of a calibration: the shipped simulated head-tracker data identified
    from the prior file instead of the model's defaults. Parameters the data determine come out the
    same (the data alone decide them) where both runs identify them; the held ones keep the prior's u.
    (A wider prior can make more combinations "determined": hold_ratio compares the data's u with the
    prior's, docs/calibration.md I-3.)"""
    examples = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples", "calibration")
    text = open(os.path.join(examples, "simulated_calibration.toml")).read()
    prior_path = os.path.abspath(f"{out}/prior/prior.toml")
    readings = os.path.abspath(os.path.join(examples, "simulated_readings.csv"))
    text = text.replace('model = "head"   # priors: the model\'s defaults',
                        f'model = "head"\ncalibration = "{prior_path}"')
    text = text.replace('csv = "simulated_readings.csv"', f'csv = "{readings}"')
    if prior_path not in text or readings not in text:
        sys.exit("could not make the calibration job with the prior")
    job = f"{out}/calibration_with_prior.toml"
    open(job, "w").write(text)
    run([vlt, "calibrate", job, "-o", f"{out}/calibration"])
    run([vlt, "calibrate", os.path.join(examples, "simulated_calibration.toml"), "-o", f"{out}/calibration_defaults"])
    with_prior = {r["parameter"]: r for r in csv.DictReader(open(f"{out}/calibration/parameters.csv"))}
    defaults = {r["parameter"]: r for r in csv.DictReader(open(f"{out}/calibration_defaults/parameters.csv"))}
    prior = {r["parameter"]: r for r in csv.DictReader(open(f"{out}/prior/parameters.csv"))}
    for name, r in with_prior.items():
        d = defaults[name]
        if r["status"] == "identified" and d["status"] == "identified":
            if abs(float(r["estimate"]) - float(d["estimate"])) > 0.5 * max(float(d["u"]), float(r["u"])):
                sys.exit(f"calibration with the prior: {name} identified at {r['estimate']}, "
                         f"from the defaults at {d['estimate']} (u {d['u']})")
        if r["status"] == "held" and abs(float(r["prior_u"]) - float(prior[name]["u"])) > 1e-12 * float(prior[name]["u"]):
            sys.exit(f"calibration with the prior: {name}'s prior u {r['prior_u']} is not the profile's {prior[name]['u']}")


def json_z(path):
    import json
    with open(path) as f:
        return json.load(f)["profile"]["z"]


if __name__ == "__main__":
    main()
