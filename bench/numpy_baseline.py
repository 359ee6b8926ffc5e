#!/usr/bin/python3
# bench/numpy_baseline.py — the numpy baseline of the Monte Carlo benchmark (docs/performance.md
# "Monte Carlo against numpy"): what a metrologist would write in Python instead of using vlt.
#
# 1. Ports the generated kernel `Forward` of a model (generated/<model>.h) to numpy MECHANICALLY:
#    every `const Scalar _tmpN = <expr>;` becomes a numpy array expression (sin/cos/sqrt/atan2 ->
#    numpy; a SinCos(a, &s, &c) pair -> np.sin(a), np.cos(a)), so the numpy model is the same
#    arithmetic as vlt's, not a re-derivation.
# 2. Checks the port against the C++ kernel through the `vlt` command: `vlt simulate --json` gives
#    the readings a tracker with a given error state shows at a point (vlt's exact inverse); the
#    numpy Forward at those readings and that error state must return the point (1e-9 m), and at
#    zero error the coordinates vlt reports (1e-12 m).
# 3. Times a JCGM 101 run of one point exactly like the C++ benchmark mcm/run/point/M:1000000
#    (bench/bench_mcm.cc): the 20 error parameters normal with the spec's u, the readings normal
#    with u(range) = 5 um + 0.5 um/m, u(angles) = 0.5 arcsec; M = 10^6 trials drawn in chunks of
#    65536; mean, covariance (JCGM 102 7.6), both 95 % coverage intervals per coordinate (7.7,
#    sorted values) and the JCGM 102 coverage-region factor (7.7.3). One thread (numpy's
#    arithmetic here is single-threaded; the BLAS is not used by these operations).
#    Twice: the straightforward port (Philox, float64 values) and the careful one (numpy's default
#    PCG64, float32 deviations from the value at the estimates, as vlt stores them; issue 33).
# 4. Runs the C++ benchmark in the same invocation (build/bench/vlt_bench) and prints both ratios.
#
# Usage: /usr/bin/python3 bench/numpy_baseline.py [--build build] [--model mirror] [--trials 1000000]
# Requires Debian's python3-numpy (scripts/lib.sh installs it).
import argparse
import json
import math
import os
import re
import subprocess
import sys
import time

import numpy as np

ARCSEC = math.pi / (180.0 * 3600.0)


def port_forward(header_path):
    """numpy source of Forward(readings, params) from the generated header."""
    text = open(header_path).read()
    m = re.search(r"void Forward\(.*?\) \{\n(.*?)\n\}\n", text, re.S)
    if not m:
        raise SystemExit(f"{header_path}: no Forward kernel")
    lines = ["def forward(readings, params, param_index):"]
    for raw in m.group(1).splitlines():
        line = raw.strip()
        if line.startswith("using ") or not line:
            continue
        a = re.match(r"const Scalar (\w+) = readings\[(\d)\];", line)
        if a:
            lines.append(f"    {a.group(1)} = readings[{a.group(2)}]")
            continue
        a = re.match(r"const Scalar (\w+) = params\[param::(\w+)\];", line)
        if a:
            lines.append(f"    {a.group(1)} = params[param_index['{a.group(2)}']]")
            continue
        a = re.match(r"const Scalar (\w+) = (.*);", line)
        if a:
            lines.append(f"    {a.group(1)} = {translate(a.group(2))}")
            continue
        # One SinCos(a, &_sinN, &_cosN) where a kernel uses both (docs/generator.md): numpy has no
        # sincos, so np.sin and np.cos, as a port by hand would write.
        if re.match(r"Scalar _sin\d+, _cos\d+;", line):
            continue
        a = re.match(r"SinCos\((.*), &(_sin\d+), &(_cos\d+)\);", line)
        if a:
            lines.append(f"    {a.group(2)} = np.sin({translate(a.group(1))})")
            lines.append(f"    {a.group(3)} = np.cos({translate(a.group(1))})")
            continue
        a = re.match(r"out\[(\d)\] = (.*);", line)
        if a:
            lines.append(f"    out{a.group(1)} = {translate(a.group(2))}")
            continue
        raise SystemExit(f"{header_path}: cannot port line: {line}")
    lines.append("    return out0, out1, out2")
    return "\n".join(lines)


def translate(expr):
    for f in ("sin", "cos", "sqrt", "atan2", "tan", "exp", "log"):
        expr = re.sub(rf"\b{f}\(", f"np.{f}(", expr)
    return expr


def param_names(header_path):
    text = open(header_path).read()
    block = re.search(r"namespace param \{\nenum Index : int \{(.*?)\};", text, re.S)
    names = re.findall(r"(\w+) = (\d+),", block.group(1))
    return [n for n, _ in sorted(names, key=lambda x: int(x[1]))]


def spec_uncertainties(spec_path, names):
    """Default u of every parameter, from the model spec (models/<model>.toml)."""
    import tomllib
    spec = tomllib.load(open(spec_path, "rb"))
    u = {p["name"]: p["u"] for p in spec["parameter"]}
    for p in spec["parameter"]:
        if p.get("distribution", "normal") != "normal":
            raise SystemExit(f"{spec_path}: {p['name']} is not normal; the baseline samples normals only")
    return np.array([u[n] for n in names])


def simulate(vlt, model, point, assignments):
    out = subprocess.run([vlt, "--json", "simulate", "--model", model, "--point", ",".join(map(repr, point))]
                         + assignments, check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def check_port(forward, names, vlt, model):
    index = {n: i for i, n in enumerate(names)}
    point = (4.0, 1.5, -0.7)
    # An error state with every parameter non-zero: a few um and arcsec.
    values = {}
    for k, n in enumerate(names):
        values[n] = (1.0 + 0.1 * k) * (3e-6 if k % 2 == 0 else 2 * ARCSEC)
    # vlt takes values with units: lengths in um, angles in arcsec, ratios as plain numbers.
    spec_units = unit_of(model, names)
    assignments = []
    for n in names:
        v = values[n]
        unit = spec_units[n]
        if unit == "m":
            assignments.append(f"{n}={v * 1e6!r}um")
        elif unit == "rad":
            assignments.append(f"{n}={v / ARCSEC!r}arcsec")
        else:
            values[n] = v = 1e-6 * (1.0 + 0.01 * len(assignments))
            assignments.append(f"{n}={v!r}")
    sim = simulate(vlt, model, point, assignments)
    r = sim["readings"]
    readings = np.array([[r["range_m"]], [r["azimuth_rad"]], [r["elevation_rad"]]])
    params = np.array([[values[n]] for n in names])
    got = np.array(forward(readings, params, index)).ravel()
    err = np.max(np.abs(got - np.array(point)))
    if err > 1e-9:
        raise SystemExit(f"numpy port of {model} Forward differs from vlt's inverse by {err:.3g} m")
    zero = np.zeros_like(params)
    reported = np.array(forward(readings, zero, index)).ravel()
    err0 = np.max(np.abs(reported - np.array(sim["reported_m"])))
    if err0 > 1e-12:
        raise SystemExit(f"numpy port of {model} Forward differs from vlt at zero error by {err0:.3g} m")
    return max(err, err0)


def unit_of(model, names):
    import tomllib
    here = os.path.dirname(os.path.abspath(__file__))
    spec = tomllib.load(open(os.path.join(here, "..", "models", f"{model}.toml"), "rb"))
    return {p["name"]: p["unit"] for p in spec["parameter"]}


def mcm_point(forward, names, u_params, readings0, trials, chunk=65536, seed=20260101, p=0.95, careful=False):
    """A JCGM 101 / 102 run of one point; returns (seconds, summary).

    careful=False: the straightforward port (Philox, every value a float64 coordinate).
    careful=True: what a careful researcher writes (issue 33): numpy's default PCG64 generator,
    the values stored as float32 deviations from the value at the estimates (as vlt stores them:
    half the memory traffic and faster sorts, no loss of the um digits), the sums in float64."""
    index = {n: i for i, n in enumerate(names)}
    rng = np.random.Generator(np.random.PCG64(seed) if careful else np.random.Philox(seed))
    n_params = len(names)
    u_read = np.array([5e-6 + 0.5e-6 * readings0[0], 0.5 * ARCSEC, 0.5 * ARCSEC])
    t0 = time.perf_counter()
    y0 = np.array(forward(readings0[:, None], np.zeros((n_params, 1)), index)).ravel()
    values = np.empty((3, trials), dtype=np.float32 if careful else np.float64)
    done = 0
    while done < trials:
        n = min(chunk, trials - done)
        z = rng.standard_normal((3 + n_params, n))
        readings = readings0[:, None] + u_read[:, None] * z[:3]
        params = u_params[:, None] * z[3:]
        x, y, zc = forward(readings, params, index)
        if careful:
            values[0, done:done + n] = x - y0[0]
            values[1, done:done + n] = y - y0[1]
            values[2, done:done + n] = zc - y0[2]
        else:
            values[0, done:done + n] = x
            values[1, done:done + n] = y
            values[2, done:done + n] = zc
        done += n
    offset = y0 if careful else np.zeros(3)
    mean = values.mean(axis=1, dtype=np.float64)
    cov = np.cov(values.astype(np.float64)) if not careful else np.cov(values, dtype=np.float64)
    q = int(math.floor(p * trials + 0.5))     # JCGM 101 7.7.1
    r_sym = (trials - q) // 2 if (trials - q) % 2 == 0 else (trials - q + 1) // 2
    intervals = []
    for a in range(3):
        s = np.sort(values[a])
        sym = (s[r_sym - 1], s[r_sym + q - 1])
        widths = s[q:] - s[:trials - q]
        r = int(np.argmin(widths))
        intervals.append(((offset[a] + sym[0], offset[a] + sym[1]), (offset[a] + s[r], offset[a] + s[r + q])))
    l_inv = np.linalg.inv(np.linalg.cholesky(cov))
    d = np.linalg.norm(l_inv @ (values - mean[:, None].astype(values.dtype)), axis=0)
    k_p = np.partition(d, q - 1)[q - 1]       # JCGM 102 7.7.3
    seconds = time.perf_counter() - t0
    return seconds, {"mean": offset + mean, "u": np.sqrt(np.diag(cov)), "intervals": intervals, "k_p": k_p}


def cpp_benchmark(build, trials):
    exe = os.path.join(build, "bench", "vlt_bench")
    name = f"mcm/run/point/M:{trials}/threads:1/"
    out_file = "/tmp/vlt_numpy_baseline_bench.json"
    subprocess.run([exe, f"--benchmark_filter=^{re.escape(name)}", f"--benchmark_out={out_file}",
                    "--benchmark_out_format=json", "--benchmark_repetitions=3",
                    "--benchmark_report_aggregates_only=true"], check=True, capture_output=True, text=True)
    data = json.load(open(out_file))
    for b in data["benchmarks"]:
        if b.get("aggregate_name") == "median":
            return b["real_time"] * {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}[b["time_unit"]], b
    raise SystemExit("no median in the C++ benchmark output")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--model", default="mirror")
    ap.add_argument("--trials", type=int, default=1000000)
    ap.add_argument("--repetitions", type=int, default=3)
    ap.add_argument("--port-only", action="store_true",
                    help="port and check the model against vlt, then stop (the test of the port)")
    args = ap.parse_args()
    here = os.path.dirname(os.path.abspath(__file__))
    header = os.path.join(here, "..", "generated", f"{args.model}.h")
    names = param_names(header)
    namespace = {"np": np}
    exec(port_forward(header), namespace)
    forward = namespace["forward"]
    vlt = os.path.join(args.build, "runtime", "vlt")
    err = check_port(forward, names, vlt, args.model)
    print(f"numpy port of {args.model} Forward checked against vlt: max |difference| {err:.2e} m")
    if args.port_only:
        return

    u_params = spec_uncertainties(os.path.join(here, "..", "models", f"{args.model}.toml"), names)
    # The benchmark's point: part (= tracker) frame (5, 0.25, -0.8) m, readings of an ideal tracker.
    sim = simulate(vlt, args.model, (5.0, 0.25, -0.8), [])
    r = sim["readings"]
    readings0 = np.array([r["range_m"], r["azimuth_rad"], r["elevation_rad"]])
    medians = {}
    for careful, label in ((False, "numpy (Philox, float64 values)"), (True, "numpy (PCG64, float32 deviations)")):
        times = []
        for _ in range(args.repetitions):
            seconds, summary = mcm_point(forward, names, u_params, readings0, args.trials, careful=careful)
            times.append(seconds)
        medians[careful] = sorted(times)[len(times) // 2]
        print(f"{label}: {args.trials} trials in {medians[careful]:.3f} s (median of {args.repetitions}): "
              f"{args.trials / medians[careful] / 1e6:.2f} M trials/s; u = {summary['u'] * 1e6} um, "
              f"k_p = {summary['k_p']:.4f}")
    cpp_s, bench = cpp_benchmark(args.build, args.trials)
    print(f"vlt:   {args.trials} trials in {cpp_s:.3f} s (median of 3, mcm/run/point threads:1): "
          f"{args.trials / cpp_s / 1e6:.2f} M trials/s; u_x = {bench.get('u_x_um', float('nan')):.3f} um")
    print(f"ratio vlt / numpy (same outputs, one core): {medians[False] / cpp_s:.2f}x")
    print(f"ratio vlt / careful numpy (PCG64, float32 storage; one core): {medians[True] / cpp_s:.2f}x")
    print(f"load average: {open('/proc/loadavg').read().split()[:3]}")


if __name__ == "__main__":
    main()
