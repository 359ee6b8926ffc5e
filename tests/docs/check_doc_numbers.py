#!/usr/bin/env python3
"""Numbers the docs quote from vlt's own runs, checked against a run (issue 36: docs that cannot
drift from the code).

Usage: check_doc_numbers.py VLT SOURCE_DIR OUT_DIR

Each check runs one example with the `vlt` given, reads its results.json and requires the doc to
contain the numbers formatted as the doc quotes them. Exit 1 with the expected text when a doc
quotes something else.
"""
import json
import os
import subprocess
import sys


def run(vlt, example, out):
    subprocess.run([vlt, "run", example, "-o", out], check=True, stdout=subprocess.DEVNULL)
    with open(os.path.join(out, "results.json"), encoding="utf-8") as f:
        return json.load(f)


def jcgm101_mass(results):
    """docs/custom-models.md, JCGM 101 9.3 (table 7): GUM u, MCM u and the shortest 95 % interval."""
    output = results["outputs"][0]
    low, high = output["mcm"]["shortest_interval"]
    return (f"{output['gum']['u']:.5f} mg; {output['mcm']['u']:.4f} mg, [{low:.4f}, {high:.4f}] mg "
            "(10⁶ trials, seed 1)")


def signed(v, decimals):
    """A number as the docs print it: the minus sign U+2212."""
    return f"{v:.{decimals}f}".replace("-", "\u2212")


def gum_h1(results):
    """docs/custom-models.md, GUM H.1: l in mm, u in nm, nu_eff, k, U in nm."""
    gum = results["outputs"][0]["gum"]
    nu = gum["dof_effective"]
    return (f"{gum['estimate'] * 1e3:.6f} mm, {gum['u'] * 1e9:.1f} nm, {nu:.2f} \u2192 {int(nu)}, "
            f"{gum['k']:.3f}, {gum['U'] * 1e9:.1f} nm")


def gum_h2(results):
    """docs/custom-models.md, GUM H.2 (table H.3): R, X, Z with u in ohm; r(R,X), r(R,Z), r(X,Z)."""
    gum = [output["gum"] for output in results["outputs"]]
    r = results["output_correlation"]
    values = ", ".join(f"{g['estimate']:.4f} ({g['u']:.4f})" for g in gum)
    return f"{values}; {signed(r[0][1], 3)}, {signed(r[0][2], 3)}, {signed(r[1][2], 3)}"


def jcgm101_additive_rectangular(results):
    """docs/custom-models.md, JCGM 101 9.2.3: GUM U; MCM u and the probabilistically symmetric interval."""
    output = results["outputs"][0]
    low, high = output["mcm"]["symmetric_interval"]
    return f"\u00b1{output['gum']['U']:.3f}; {output['mcm']['u']:.3f}, [{signed(low, 3)}, {signed(high, 3)}]"


def jcgm101_additive_dominant(results):
    """docs/custom-models.md, JCGM 101 9.2.4: GUM u and U; the MCM probabilistically symmetric interval."""
    output = results["outputs"][0]
    low, high = output["mcm"]["symmetric_interval"]
    return f"{output['gum']['u']:.3f}, \u00b1{output['gum']['U']:.3f}; [{signed(low, 2)}, {signed(high, 2)}]"


CHECKS = [
    ("docs/custom-models.md", "examples/custom/gum_h1_end_gauge.toml", gum_h1),
    ("docs/custom-models.md", "examples/custom/gum_h2_impedance.toml", gum_h2),
    ("docs/custom-models.md", "examples/custom/jcgm101_additive_rectangular.toml", jcgm101_additive_rectangular),
    ("docs/custom-models.md", "examples/custom/jcgm101_additive_dominant.toml", jcgm101_additive_dominant),
    ("docs/custom-models.md", "examples/custom/jcgm101_mass.toml", jcgm101_mass),
]


def main():
    vlt, top, out = sys.argv[1], sys.argv[2], sys.argv[3]
    failures = 0
    for doc, example, quote in CHECKS:
        expected = quote(run(vlt, os.path.join(top, example), os.path.join(out, os.path.basename(example))))
        with open(os.path.join(top, doc), encoding="utf-8") as f:
            if expected not in f.read():
                print(f"{doc}: does not quote the run of {example}: expected '{expected}'")
                failures += 1
    print(f"doc numbers: {len(CHECKS)} checked, {failures} differ")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
