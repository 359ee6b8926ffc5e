#!/usr/bin/env python3
"""No function in runtime/ and symbolic/ is longer than the limit (docs/README.md, "How the code
reads"): a function is counted from the first line of its signature to its closing brace, the
lambdas and blocks inside it included.

Usage: check_function_length.py SOURCE_DIR [LIMIT=150]

The sources are read as C++ tokens enough to find function bodies: comments, string and character
literals and raw strings are blanked first (a brace in a string is not a brace), then every '{'
is classified by the text since the previous ';', '{' or '}': a namespace, a class, struct, union
or enum, or a function body (the text ends with ')' and what may follow a parameter list: const,
noexcept, override, final, a trailing return type, a member-initializer list, a requires-clause).
A brace inside a function body belongs to that function. Prints each function over the limit and
exits 1 if there is one.
"""
import os
import re
import sys

FOLDERS = ["runtime", "symbolic"]


def blank_literals(text):
    """Comments and literals replaced by spaces, line breaks kept (so line numbers stay)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and i + 1 < n and text[i + 1] == '"' and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if m:
                end = text.find(")" + m.group(1) + '"', i + m.end())
                end = n if end < 0 else end + len(m.group(1)) + 2
                out.append(re.sub(r"[^\n]", " ", text[i:end]))
                i = end
            else:
                out.append(c)
                i += 1
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


TYPE = re.compile(r"\b(class|struct|union|enum)\b")
FUNCTION_TAIL = re.compile(
    r"\)\s*(const|noexcept|override|final|mutable|&|&&|\s)*"
    r"(->[^{;]*)?(requires[^{;]*)?(:[^{;]*)?$", re.S)


def functions(text):
    """(first line, last line, signature) of every function body in the text."""
    code = blank_literals(text)
    found, stack = [], []  # stack of (kind, start line, signature)
    last_stop = 0
    for i, c in enumerate(code):
        if c not in "{};":
            continue
        if c == ";":
            last_stop = i + 1
            continue
        if c == "}":
            if stack:
                kind, start, sig = stack.pop()
                if kind == "function" and not any(k == "function" for k, _, _ in stack):
                    found.append((start, code.count("\n", 0, i) + 1, sig))
            last_stop = i + 1
            continue
        head = code[last_stop:i]
        stripped = "\n".join(l for l in head.split("\n") if not l.strip().startswith("#")).strip()
        if any(k == "function" for k, _, _ in stack):
            kind = "block"
        elif re.search(r"\bnamespace\b", stripped) or stripped.startswith("extern"):
            kind = "namespace"
        elif TYPE.search(stripped) and "(" not in stripped.split("{")[0]:
            kind = "type"
        elif FUNCTION_TAIL.search(stripped) or re.search(r"\]\s*\([^)]*\)[^{]*$", stripped):
            kind = "function"
        else:
            kind = "block"
        offset = last_stop + len(head) - len(head.lstrip())
        start = code.count("\n", 0, offset) + 1
        stack.append((kind, start, " ".join(stripped.split())[:100]))
        last_stop = i + 1
    return found


def main():
    top = sys.argv[1]
    limit = int(sys.argv[2]) if len(sys.argv) > 2 else 150
    longest, problems = [], []
    for folder in FOLDERS:
        for dirpath, _, files in os.walk(os.path.join(top, folder)):
            for f in sorted(files):
                if not f.endswith((".cc", ".h")):
                    continue
                path = os.path.join(dirpath, f)
                for start, end, sig in functions(open(path, encoding="utf-8").read()):
                    lines = end - start + 1
                    rel = os.path.relpath(path, top)
                    longest.append((lines, f"{rel}:{start}", sig))
                    if lines > limit:
                        problems.append(f"{rel}:{start}: {lines} lines (limit {limit}): {sig}")
    for p in problems:
        print(p)
    longest.sort(reverse=True)
    if longest:
        print(f"longest: {longest[0][0]} lines, {longest[0][1]}")
    print(f"function length: {len(longest)} functions, {len(problems)} over {limit} lines")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
