#!/usr/bin/env python3
"""Run by CTest (tests/cli.cmake): `vlt run` on the job `vlt plan` wrote (planned_job.toml) must
give, from its points.csv and tasks.csv, exactly the objective plan.json reports at the
recommended station (the numbers in the CSVs read back to the same doubles).
  plan_reproduced.py VLT PLAN_DIR RUN_DIR"""
import csv
import json
import subprocess
import sys

vlt, plan_dir, run_dir = sys.argv[1:4]
plan = json.load(open(f"{plan_dir}/plan.json"))
rec = plan["recommended"]
assert rec["feasible"], rec
subprocess.run([vlt, "--quiet", "run", f"{plan_dir}/planned_job.toml", "--no-mcm", "-o", run_dir], check=True)
points = list(csv.DictReader(open(f"{run_dir}/points.csv")))
tasks = list(csv.DictReader(open(f"{run_dir}/tasks.csv")))
total = 0.0
for term in rec["terms"]:
    if term["quantity"] == "points":
        value = max(float(p["U_norm_um"]) for p in points) * 1e-6
    else:
        task, quantity = term["quantity"].split(".", 1)
        row = [t for t in tasks if t["task"] == task and t["quantity"] == quantity]
        assert len(row) == 1, term
        value = float(row[0]["U"]) * 1e-6  # tasks.csv: U of a length in um
    if abs(value - term["U"]) > 1e-12 * term["U"]:
        sys.exit(f"{term['quantity']}: vlt run gives {value!r} m, plan.json {term['U']!r} m")
    total += term["weight"] * value
if abs(total - rec["objective"]) > 1e-12 * rec["objective"]:
    sys.exit(f"objective: vlt run gives {total!r} m, plan.json {rec['objective']!r} m")
# The station written is the one reported.
station = [float(v.split()[0]) for v in
           (line.split("=", 1)[1].strip().strip("'\"") for line in open(f"{plan_dir}/planned_job.toml")
            if line.strip().startswith(("tx", "ty", "tz")))]
if [round(v, 6) for v in rec["station"]] != station:
    sys.exit(f"planned_job.toml station {station} != plan.json {rec['station']}")
print(f"ok: objective {rec['objective']!r} m reproduced by vlt run")
