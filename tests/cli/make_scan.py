#!/usr/bin/env python3
"""Writes a scan job for the large-report test (tests/cli.cmake report_browser_scan_large):
N nominal points (SpatialAnalyzer-style names) on a square grid, 4 m x 4 m at z = 0.5 m in front
of a `mirror` tracker, one plane over all of them, GUM only: the job of jobs/scan_2000.toml.
Usage: make_scan.py N DIR -> DIR/scan.toml, DIR/scan.csv"""
import math
import os
import sys

n, out = int(sys.argv[1]), sys.argv[2]
os.makedirs(out, exist_ok=True)
side = math.ceil(math.sqrt(n))
with open(os.path.join(out, "scan.csv"), "w") as f:
    f.write("name,x,y,z\n")
    for k in range(n):
        i, j = divmod(k, side)
        f.write("Wing::Skin::S%d,%.6f,%.6f,0.5\n" % (k, 2.0 + 4.0 * i / (side - 1), -2.0 + 4.0 * j / (side - 1)))
# The job is tests/cli/jobs/scan_2000.toml with this CSV.
template = os.path.join(os.path.dirname(os.path.abspath(__file__)), "jobs", "scan_2000.toml")
with open(template) as f:
    job = f.read().replace("scan_2000.csv", "scan.csv").replace('name = "scan_2000"', 'name = "scan_%d"' % n)
with open(os.path.join(out, "scan.toml"), "w") as f:
    f.write(job)
