#!/usr/bin/env python3
"""The per-point files of a run (docs/results.md "Detail of the per-point files"), checked against
each other by numpy, not by vlt:

  check_points_npy.py VLT WORKDIR full JOB.toml [ARGS...]
      runs JOB with [output] detail = "full" and arrays = true; every field of points.npy must be
      the number points.jsonl holds for it, bit for bit (JSON's shortest round trip reads back the
      same double), and the budget fields the rows of budget.csv.
  check_points_npy.py VLT WORKDIR compact N
      generates a scan of N points (make_scan.py), runs it with arrays = true: the default detail of
      a job that size is compact, points.csv has one row per point of at most 100 bytes, no
      points.jsonl or budget.csv; each row is points.npy's point rounded as documented, and its
      dominant input and share are those of points.npy's budget fields (argmax of sum over axes of
      contribution^2, over trace(covariance)).
"""
import csv
import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np


def run_job(vlt, job_dir, job_file, args, extra_output):
    with open(job_file) as f:
        text = f.read()
    if "[output]" in text:
        sys.exit("the job must not have an [output] section")
    copy = os.path.join(job_dir, os.path.basename(job_file))
    with open(copy, "w") as f:
        f.write(text + "\n[output]\n" + extra_output)
    out = os.path.join(job_dir, "out")
    subprocess.run([vlt, "run", copy, "-q", "-o", out] + args, check=True)
    return out


def same(a, b, what):
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape or not np.array_equal(a, b):
        sys.exit(f"{what}: points.npy {a.tolist()} != {b.tolist()}")


def check_full(vlt, work, job_file, args):
    src = os.path.dirname(os.path.abspath(job_file))
    for name in os.listdir(src):
        if name.endswith(".csv"):
            shutil.copy(os.path.join(src, name), work)
    out = run_job(vlt, work, job_file, args, 'detail = "full"\narrays = true\n')
    a = np.load(os.path.join(out, "points.npy"), mmap_mode="r")
    with open(os.path.join(out, "points.jsonl")) as f:
        points = [json.loads(line) for line in f]
    results = json.load(open(os.path.join(out, "results.json")))
    assert results["points_array"] == "points.npy" and results["point_detail"] == "full"
    if len(a) != len(points):
        sys.exit(f"points.npy has {len(a)} records for {len(points)} points")
    for rec, p in zip(a, points):
        g = p["gum"]
        if rec["name"].decode() != p["name"]:
            sys.exit(f"name {rec['name']} != {p['name']}")
        assert rec["face"] == (1 if p["face"] == "back" else 0)
        same(rec["readings"], [p["readings"][k] for k in ("range", "azimuth", "elevation")], "readings")
        if p["nominal"] is not None:
            same(rec["nominal"], p["nominal"], "nominal")
        for field in ("estimate", "covariance", "u", "k", "U", "U_norm"):
            same(rec[field], g[field], field)
        same(rec["ellipsoid_k"], g["ellipsoid"]["k"], "ellipsoid k")
        same(rec["ellipsoid_semi_axes"], g["ellipsoid"]["semi_axes"], "ellipsoid semi-axes")
        same(rec["ellipsoid_directions"], g["ellipsoid"]["directions"], "ellipsoid directions")
        los = g["line_of_sight"]
        same(rec["u_line_of_sight"], [los["u_radial"], los["u_horizontal"], los["u_vertical"]], "line of sight")
        same(rec["tracker_estimate"], g["tracker_frame"]["estimate"], "tracker estimate")
        same(rec["tracker_covariance"], g["tracker_frame"]["covariance"], "tracker covariance")
        same(rec["second_order_variance"], g["second_order"]["variance"], "second-order variance")
        ratio = [math.inf if r is None else r for r in g["second_order"]["ratio"]]
        same(rec["second_order_ratio"], ratio, "second-order ratio")
        assert bool(rec["gum_reliable"]) == g["second_order"]["reliable"]
        assert bool(rec["second_order_decided"]) == g["second_order"]["decided"]
        if p.get("mcm"):
            m = p["mcm"]
            same(rec["mcm_mean"], m["mean"], "mcm mean")
            same(rec["mcm_covariance"], m["covariance"], "mcm covariance")
            same(rec["mcm_coverage_factor"], m["coverage_factor"], "mcm coverage factor")
            same(rec["mcm_low"], [x["symmetric_interval"][0] for x in m["axes"]], "mcm low")
            same(rec["mcm_high"], [x["symmetric_interval"][1] for x in m["axes"]], "mcm high")
            v = p["validation"]
            same(rec["d_low"], [x["d_low"] for x in v["axes"]], "d_low")
            same(rec["d_high"], [x["d_high"] for x in v["axes"]], "d_high")
            same(rec["delta"], [x["delta"] for x in v["axes"]], "delta")
            same(rec["region_worst_ratio"], v["region"]["worst_ratio"], "region worst ratio")
            assert rec["gum_vs_mcm"].decode() == v["verdict"], (rec["gum_vs_mcm"], v["verdict"])
    # The budget fields against budget.csv (its numbers are shortest round trips too).
    names = a.dtype.names
    with open(os.path.join(out, "budget.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    index = {p["name"]: i for i, p in enumerate(points)}
    for row in rows:
        rec = a[index[row["point"]]]
        key = row["input"]
        if "contribution:" + key not in names:
            sys.exit(f"points.npy has no budget field for '{key}'")
        contribution = [float(row[f"contribution_{c}_um"]) for c in "xyz"]
        same(np.asarray(rec["contribution:" + key]) * 1e6, contribution, f"contribution of {key}")
        if row["group"] != "correlation":
            same(rec["sensitivity:" + key], [float(row[f"sensitivity_{c}"]) for c in "xyz"], f"sensitivity of {key}")
        if row["group"] == "reading":
            same(rec["u_readings"][["range", "azimuth", "elevation"].index(key)], float(row["u"]), f"u of {key}")
    print(f"points.npy: {len(a)} points, {len(names)} fields, the same numbers as points.jsonl and budget.csv")


def rounded(v, decimals):
    text = f"{v:.{decimals}f}"
    if decimals > 0:
        text = text.rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def rounded_up(v, digits):
    """An uncertainty rounded up to `digits` significant digits, trailing zeros kept."""
    if v <= 0:
        return "0"
    decimals = min(17, max(0, digits - 1 - math.floor(math.log10(v))))
    return f"{math.ceil(v * 10 ** decimals) / 10 ** decimals:.{decimals}f}"


def check_compact(vlt, work, n):
    here = os.path.dirname(os.path.abspath(__file__))
    subprocess.run([sys.executable, os.path.join(here, "make_scan.py"), str(n), work], check=True,
                   stdout=subprocess.DEVNULL)
    out = run_job(vlt, work, os.path.join(work, "scan.toml"), [], "arrays = true\n")
    for absent in ("points.jsonl", "budget.csv"):
        if os.path.exists(os.path.join(out, absent)):
            sys.exit(f"{absent} written for a scan of {n} points (compact by default)")
    results = json.load(open(os.path.join(out, "results.json")))
    assert results["point_detail"] == "compact" and results["points_file"] is None
    size = os.path.getsize(os.path.join(out, "points.csv"))
    if size > 100 * n:
        sys.exit(f"points.csv: {size / n:.1f} bytes per point (at most 100)")
    a = np.load(os.path.join(out, "points.npy"), mmap_mode="r")
    inputs = [f[len("contribution:"):] for f in a.dtype.names if f.startswith("contribution:")]
    contributions = np.stack([a["contribution:" + k] for k in inputs], axis=1)  # N x inputs x 3
    trace = np.trace(a["covariance"], axis1=1, axis2=2)
    # A row's variance is contribution^2 (c u, signed as c is); the correlation row's contribution
    # is the signed square root of its variance (docs/results.md).
    variance = contributions ** 2
    if "correlations" in inputs:
        k = inputs.index("correlations")
        variance[:, k] = contributions[:, k] * np.abs(contributions[:, k])
    share = variance.sum(axis=2) / trace[:, None]
    with open(os.path.join(out, "points.csv"), newline="") as f:
        rows = list(csv.DictReader(f))
    if len(rows) != n:
        sys.exit(f"points.csv has {len(rows)} rows for {n} points")
    for i, row in enumerate(rows):
        rec = a[i]
        want = [rec["name"].decode()]
        want += [rounded(rec["estimate"][c] * 1e3, 4) for c in range(3)]
        want += [rounded_up(rec["U"][c] * 1e6, 3) for c in range(3)]
        want += [rounded_up(rec["U_norm"] * 1e6, 3)]
        best = int(np.argmax(share[i]))
        want += [inputs[best], rounded(share[i][best], 3), "yes" if rec["gum_reliable"] else "no"]
        got = [row[k] for k in ("name", "x_mm", "y_mm", "z_mm", "U_x_um", "U_y_um", "U_z_um", "U_norm_um",
                                "dominant_input", "dominant_share", "gum_reliable")]
        # The share is the engine's own sum in its order: its last digit may differ at a tie.
        if got[:9] + got[10:] != want[:9] + want[10:] or abs(float(got[9]) - float(want[9])) > 1e-3:
            sys.exit(f"row {i}: {got} != {want}")
    print(f"compact points.csv: {n} rows, {size / n:.1f} bytes per point, each the rounded points.npy record")


def main():
    vlt, work, mode = sys.argv[1:4]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    if mode == "full":
        check_full(vlt, work, sys.argv[4], sys.argv[5:])
    else:
        check_compact(vlt, work, int(sys.argv[4]))


if __name__ == "__main__":
    main()
