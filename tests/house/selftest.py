#!/usr/bin/env python3
"""The house-rule checkers catch what they must: a small tree with a cycle in the rule, an include
the rule does not allow, an internal header used outside its folder, a CLI that includes an
internal header, and a function one line over the limit (with braces in strings and a raw string
that must not count) — and pass the same tree once it is mended."""
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def write(root, rel, text):
    path = os.path.join(root, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def run(script, *args):
    p = subprocess.run([sys.executable, os.path.join(HERE, script), *args], capture_output=True, text=True)
    return p.returncode, p.stdout


def table(rows):
    return "| folder | holds | may use |\n|---|---|---|\n" + "".join(f"| `{f}/` | x | {u} |\n" for f, u in rows) + "\n"


def body(lines):
    inner = "".join(f"  x += {i};\n" for i in range(lines - 2))
    return "int F(int x) {\n" + inner + "}\n"


def main():
    failures = []
    with tempfile.TemporaryDirectory() as root:
        write(root, "runtime/src/low/a.h", "#pragma once\n")
        write(root, "runtime/src/low/internal.h", "#pragma once\n")
        write(root, "runtime/src/high/b.cc", '#include "low/a.h"\n#include "low/internal.h"\n'
                                            'namespace vlt::low_internal {\n}\n')
        write(root, "runtime/cli/main.cc", '#include "vlt/x.h"\n#include "high/b.h"\n')
        write(root, "python/m.cc", '#include "vlt/x.h"\n')
        write(root, "docs/README.md", table([("low", "`high/`"), ("high", "`low/`")]))
        rc, out = run("check_layering.py", root)
        for expected in ["cycle in the rule", "low/'s internal header outside low/", "runtime/cli/main.cc: #include \"high/b.h\"",
                         "namespace vlt::low_internal: high/'s private names belong in vlt::high_internal"]:
            if expected not in out:
                failures.append(f"layering: not reported: {expected}\n{out}")
        if rc == 0:
            failures.append("layering: exit 0 with violations")
        write(root, "docs/README.md", table([("low", "—"), ("high", "`low/`")]))
        write(root, "runtime/src/high/b.cc", '#include "low/a.h"\nnamespace vlt::high_internal {\nnamespace {\n}\n}\n')
        write(root, "runtime/cli/main.cc", '#include "vlt/x.h"\n#include "commands.h"\n')
        write(root, "runtime/cli/commands.h", "#pragma once\n")
        rc, out = run("check_layering.py", root)
        if rc != 0:
            failures.append(f"layering: mended tree refused\n{out}")

        # A function of 151 lines whose strings hold braces, after a raw string of 200 lines.
        raw = 'const char* kText = R"(\n' + "}\n{\n" * 100 + ')";\n'
        long_fn = body(151).replace("  x += 0;\n", '  const char* s = "}{}}";\n', 1).replace("  x += 1;\n", "  char c = '}';\n", 1)
        write(root, "runtime/src/low/f.cc", raw + "namespace n {\n" + long_fn + "}  // namespace n\n")
        rc, out = run("check_function_length.py", root, "150")
        if rc == 0 or "f.cc:" not in out or "151 lines" not in out:
            failures.append(f"function length: 151 lines not reported\n{out}")
        write(root, "runtime/src/low/f.cc", raw + "namespace n {\n" + body(150) + "}  // namespace n\n")
        rc, out = run("check_function_length.py", root, "150")
        if rc != 0:
            failures.append(f"function length: 150 lines refused\n{out}")
    for f in failures:
        print(f)
    print(f"house rules self-test: {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
