#!/usr/bin/env python3
"""Run by CTest (python/CMakeLists.txt `python_pip_install`): `pip install --no-build-isolation
--no-deps --no-index --target DIR SOURCE` must build and install the module with what the
distribution ships (setuptools, wheel; no package index), and a fresh interpreter with only DIR on
its path must import it from there and run the embedded demo job's tracker through the GUM.

usage: check_pip_install.py SOURCE DIR
"""
import os
import shutil
import subprocess
import sys


def main():
    source, target = sys.argv[1:3]
    shutil.rmtree(target, ignore_errors=True)
    done = subprocess.run([sys.executable, "-m", "pip", "install", "--no-build-isolation", "--no-deps",
                           "--no-index", "--disable-pip-version-check", "--target", target, source],
                          capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"pip install failed (exit {done.returncode}):\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = target
    probe = (
        "import os, sys, vlt, numpy as np\n"
        f"assert os.path.dirname(vlt.__file__) == {os.path.abspath(target)!r}, vlt.__file__\n"
        "names = [m['name'] for m in vlt.models()]\n"
        "assert 'mirror' in names and 'head' in names, names\n"
        "job = {'tracker': {'model': 'mirror', 'noise': {'range': '1 um + 0.2 um/m', 'azimuth': '0.1 arcsec',"
        " 'elevation': '0.1 arcsec'}}, 'plan': {'unit': 'm', 'point': [{'name': 'P', 'x': 4.0, 'y': 1.0, 'z': 0.5}]}}\n"
        "r = vlt.run(job, monte_carlo=False)\n"
        "U = np.asarray(r['U'])\n"
        "assert U.shape == (1, 3) and np.all(np.isfinite(U)) and np.all(U > 0) and np.all(U < 1e-3), U\n"
        "print(vlt.__file__, U[0] * 1e6)\n")
    run = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, cwd=target)
    if run.returncode != 0:
        sys.exit(f"the installed module failed:\n{run.stdout}\n{run.stderr}")
    version = [d for d in os.listdir(target) if d.endswith(".dist-info")]
    print(f"ok: pip installed vlt {version[0][4:-10] if version else '?'} into {target} and it ran a job: {run.stdout.strip()}")


if __name__ == "__main__":
    main()
