"""The Python twin of main.cc (docs/python.md): runs the demo job GUM only through an installed
vlt module and prints the same three lines.
  PYTHONPATH=<prefix>/lib/python3.X/dist-packages python3 consumer.py demo.toml
(demo.toml from `vlt demo --show-job`: the job `vlt demo` runs, named vlt-demo)."""
import sys

if len(sys.argv) != 2:
    print(__doc__.strip() + "\nusage: python3 consumer.py JOB.toml", file=sys.stderr)
    sys.exit(2)

import numpy as np  # noqa: E402 (the usage above needs neither)
import vlt  # noqa: E402

r = vlt.run(sys.argv[1], monte_carlo=False)
worst = int(np.argmax(np.linalg.norm(r["U"], axis=1)))
print(f"vlt {r['vlt_version']}: job '{r['job']['name']}', {len(r['names'])} points, {len(r['tasks'])} tasks")
print(f"worst point {r['names'][worst]}: |U| = {np.linalg.norm(r['U'][worst]) * 1e6:.1f} µm")
task = r["tasks"][0]
print(f"task {task['name']}: {task['quantities'][0]} = {task['gum']['value'][0]:.6f}, U = {task['gum']['U'][0] * 1e6:.2f} µm")
