#!/usr/bin/env python3
"""The layering of runtime/ (docs/README.md, "Layering"), checked from the sources and the objects.

Usage: check_layering.py SOURCE_DIR [OBJECT_DIR]

The rule is the table of docs/README.md whose header row is "| folder | holds | may use |": one row
per folder of runtime/src (plus `generated/`, the emitted kernels), the folders it may use directly
in backticks in the last column ("—" for none). Checked:
  1. every folder of runtime/src has a row and every row a folder;
  2. the rule has no cycle (no folder may use itself through others);
  3. includes: a file of runtime/src/F includes a header of runtime/src/G only if G is F or F may
     use G; a header named internal.h (or *_internal.h) is never included outside its folder;
  4. the command line (runtime/cli) and the Python module (python/) include public headers
     (vlt/*.h) and their own files only;
  5. namespaces: a file of runtime/src/F declares its private names in vlt::F_internal (nested
     namespaces inside it allowed) or extends a namespace of the public headers (vlt/*.h); no
     other named namespace;
  6. calls (with OBJECT_DIR, the object files of the runtime as CMake builds them): every symbol a
     folder's objects need that another folder's objects define is a use the rule allows. This is
     what the include check cannot see: a call through a public header vlt/*.h into a folder the
     caller may not use.
Prints every violation and exits 1 if there is one.
"""
import os
import re
import subprocess
import sys

HEADER = re.compile(r"^\|\s*folder\s*\|\s*holds\s*\|\s*may use\s*\|\s*$")
ROW = re.compile(r"^\|\s*`([a-z_]+)/`\s*\|(.*)\|(.*)\|\s*$")
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def read_rule(readme):
    """{folder: set of folders it may use} from the table under the "may use" header."""
    rule, in_table = {}, False
    for line in open(readme, encoding="utf-8"):
        line = line.rstrip("\n")
        if HEADER.match(line):
            in_table = True
            continue
        if in_table:
            if not line.startswith("|"):
                break
            m = ROW.match(line)
            if m:
                rule[m.group(1)] = set(re.findall(r"`([a-z_]+)/`", m.group(3)))
    if not rule:
        sys.exit(f"{readme}: no layering table (header '| folder | holds | may use |')")
    return rule


def find_cycles(rule):
    """Folders that can reach themselves through the rule, with one path each."""
    problems = []
    for start in sorted(rule):
        stack, seen = [(start, [start])], set()
        while stack:
            node, path = stack.pop()
            for nxt in sorted(rule.get(node, ())):
                if nxt == start:
                    problems.append("cycle in the rule: " + " -> ".join(path + [start]))
                    stack = []
                    break
                if nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, path + [nxt]))
    return problems


def source_files(root):
    for dirpath, _, files in os.walk(root):
        for f in sorted(files):
            if f.endswith((".cc", ".h")):
                yield os.path.join(dirpath, f)


def is_internal_header(name):
    base = os.path.basename(name)
    return base == "internal.h" or base.endswith("_internal.h")


def check_includes(src, rule, folders):
    problems = []
    for path in source_files(src):
        folder = os.path.relpath(path, src).split(os.sep)[0]
        for inc in INCLUDE.findall(open(path, encoding="utf-8").read()):
            target = inc.split("/")[0]
            if "/" not in inc or target not in folders or target == folder:
                continue
            where = f"{os.path.relpath(path, os.path.dirname(os.path.dirname(src)))}: #include \"{inc}\""
            if is_internal_header(inc):
                problems.append(f"{where}: {target}/'s internal header outside {target}/")
            elif target not in rule.get(folder, set()):
                problems.append(f"{where}: {folder}/ may not use {target}/")
    return problems


NAMESPACE = re.compile(r"^\s*namespace\s+([A-Za-z_][\w:]*)\s*\{", re.M)


def public_namespaces(top):
    """The namespaces the public headers (runtime/include/vlt/*.h) declare, below vlt."""
    names = set()
    include = os.path.join(top, "runtime", "include", "vlt")
    for path in source_files(include):
        for name in NAMESPACE.findall(open(path, encoding="utf-8").read()):
            parts = [p for p in name.split("::") if p != "vlt"]
            if parts:
                names.add(parts[0])
    return names


def check_namespaces(src, top):
    """Private names of runtime/src/F live in vlt::F_internal (docs/README.md "Namespaces")."""
    problems = []
    public = public_namespaces(top)
    for path in source_files(src):
        folder = os.path.relpath(path, src).split(os.sep)[0]
        own = folder + "_internal"
        for name in NAMESPACE.findall(open(path, encoding="utf-8").read()):
            parts = [p for p in name.split("::") if p != "vlt"]
            if not parts or parts[0] == own or parts[0] in public:
                continue
            # A namespace nested in the folder's own (namespace lanes { inside vlt::base_internal).
            if len(name.split("::")) == 1 and re.search(r"namespace\s+(vlt::)?" + own + r"\b", open(path, encoding="utf-8").read()):
                continue
            problems.append(f"{os.path.relpath(path, top)}: namespace {name}: {folder}/'s private names belong in vlt::{own}")
    return problems


def check_public_only(top, folders, dirs):
    """The CLI and the Python module include vlt/*.h and files of their own folder only."""
    problems = []
    for d in dirs:
        for path in source_files(os.path.join(top, d)):
            own = set(os.listdir(os.path.dirname(path)))
            for inc in INCLUDE.findall(open(path, encoding="utf-8").read()):
                if inc.startswith("vlt/") or ("/" not in inc and inc in own):
                    continue
                problems.append(f"{os.path.relpath(path, top)}: #include \"{inc}\": not a public header (vlt/*.h)")
    return problems


def object_folder(obj_dir, path):
    rel = os.path.relpath(path, obj_dir).split(os.sep)
    if rel[0] == "src":
        return rel[1]
    if "generated" in rel:
        return "generated"
    return None


def nm(path, *flags):
    out = subprocess.run(["nm", "-C", *flags, path], capture_output=True, text=True, check=True).stdout
    return out.splitlines()


def check_calls(obj_dir, rule):
    defined, needed = {}, []
    for dirpath, _, files in os.walk(obj_dir):
        for f in sorted(files):
            if not f.endswith(".o"):
                continue
            path = os.path.join(dirpath, f)
            folder = object_folder(obj_dir, path)
            if folder is None:
                continue
            # Strong definitions only: code (T), data (D, B, R). Inline functions and templates
            # (W, V, u) are defined wherever they are used and tie no folder to another.
            for line in nm(path, "--defined-only"):
                parts = line.split(None, 2)
                if len(parts) == 3 and parts[1] in "TDBR":
                    defined.setdefault(parts[2], set()).add(folder)
            for line in nm(path, "--undefined-only"):
                needed.append((folder, os.path.relpath(path, obj_dir), line.split(None, 1)[-1]))
    problems, seen = [], set()
    for folder, obj, symbol in needed:
        for owner in sorted(defined.get(symbol, ())):
            if owner != folder and owner not in rule.get(folder, set()) and (obj, owner) not in seen:
                seen.add((obj, owner))
                problems.append(f"{obj} calls {symbol} of {owner}/: {folder}/ may not use {owner}/")
    if not defined:
        problems.append(f"{obj_dir}: no object files (build the runtime first)")
    return problems


def main():
    top = sys.argv[1]
    src = os.path.join(top, "runtime", "src")
    rule = read_rule(os.path.join(top, "docs", "README.md"))
    folders = {d for d in os.listdir(src) if os.path.isdir(os.path.join(src, d))}
    problems = []
    for f in sorted(folders - set(rule)):
        problems.append(f"runtime/src/{f}/ has no row in the layering table of docs/README.md")
    for f in sorted(set(rule) - folders - {"generated"}):
        problems.append(f"docs/README.md: layering row `{f}/` names no folder of runtime/src")
    for f, uses in sorted(rule.items()):
        for u in sorted(uses - set(rule)):
            problems.append(f"docs/README.md: `{f}/` may use `{u}/`, which has no row")
    problems += find_cycles(rule)
    problems += check_includes(src, rule, folders)
    problems += check_public_only(top, folders, [os.path.join("runtime", "cli"), "python"])
    problems += check_namespaces(src, top)
    if len(sys.argv) > 2:
        problems += check_calls(sys.argv[2], rule)
    for p in problems:
        print(p)
    print(f"layering: {len(rule)} folders, {len(problems)} violations")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
