#!/usr/bin/env python3
"""Run by CTest (tests/calibration.cmake): the calibration file vlt just wrote (NEW) must equal the one
shipped in examples/ (OLD): every key and every text the same, except the ones that record when and
from where it was made (created, vlt_version, the data files' paths, and the file's checksum of its
own text, which covers them), and every number the same to
1e-9 relative, every correlation coefficient to 1e-12 (of its full scale, 1). Not bit for bit:
chi2 and the Birge ratio are sums of hundreds of squared residuals, the correlations come out of a
dense factorisation, and their last digits follow the BLAS kernels of the processor (seen:
chi2 = 144.42086781870512 on one x86-64 machine and 144.4208678196114 on another, 6e-12 apart; a
correlation of 1.6e-7 that is 5e-14 apart; a parameter the data barely see, estimate 1.4e-8 with
u 2e-6, 2e-9 relative apart between an AVX2 and an AVX-512 machine): a parameter's estimate is then
compared to 1e-9 relative or to 1e-9 of its own u, whichever is larger. A regression moves them far
more.

Usage: compare_calibration.py NEW OLD
"""
import math
import sys
import tomllib

IGNORED = {"created", "vlt_version", "file", "content_sha256"}
RELATIVE = 1e-9
CORRELATION_ABSOLUTE = 1e-12


def compare(new, old, path, problems, absolute=0.0):
    if isinstance(old, dict) and isinstance(new, dict):
        for key in sorted(set(old) | set(new)):
            if key in IGNORED:
                continue
            if key not in new or key not in old:
                problems.append(f"{path}{key}: only in {'the shipped file' if key in old else 'the new file'}")
                continue
            # An estimate beside its u: a billionth of that u is below any regression.
            u = old.get("u") if key == "estimate" else None
            floor = RELATIVE * abs(u) if isinstance(u, (int, float)) else 0.0
            compare(new[key], old[key], f"{path}{key}.", problems, floor)
    elif isinstance(old, list) and isinstance(new, list):
        if len(old) != len(new):
            problems.append(f"{path.rstrip('.')}: {len(new)} entries, shipped {len(old)}")
            return
        for i, (n, o) in enumerate(zip(new, old)):
            compare(n, o, f"{path.rstrip('.')}[{i}].", problems)
    elif isinstance(old, float) or isinstance(new, float):
        if not (isinstance(new, (int, float)) and isinstance(old, (int, float))):
            problems.append(f"{path.rstrip('.')}: {new!r}, shipped {old!r}")
        elif path.startswith("correlation."):
            if not abs(new - old) <= CORRELATION_ABSOLUTE:
                problems.append(f"{path.rstrip('.')}: {new!r}, shipped {old!r} (beyond {CORRELATION_ABSOLUTE})")
        elif not math.isclose(new, old, rel_tol=RELATIVE, abs_tol=absolute):
            problems.append(f"{path.rstrip('.')}: {new!r}, shipped {old!r} (beyond {RELATIVE} relative"
                            + (f" and {absolute:.3g} absolute)" if absolute else ")"))
    elif new != old:
        problems.append(f"{path.rstrip('.')}: {new!r}, shipped {old!r}")


def main():
    new_path, old_path = sys.argv[1], sys.argv[2]
    with open(new_path, "rb") as f:
        new = tomllib.load(f)
    with open(old_path, "rb") as f:
        old = tomllib.load(f)
    problems = []
    compare(new, old, "", problems)
    for p in problems:
        print(p)
    if problems:
        print(f"{new_path} differs from {old_path}: regenerate the example (docs/calibration.md) or find the regression")
        return 1
    print(f"ok: {new_path} matches {old_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
