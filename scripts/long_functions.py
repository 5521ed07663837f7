#!/usr/bin/env python3
"""List function bodies longer than a limit (default 150 lines) in C++/CUDA sources.

A heuristic scanner, not a parser: comments, strings and character literals are
blanked, then a '{' that follows ')' (optionally with const, noexcept, override,
a trailing return type or a constructor's initialiser list) at namespace or class
level opens a function body. Lambdas and nested blocks count toward the function
that holds them. Usage: long_functions.py [--limit N] DIR_OR_FILE...
"""
import argparse
import os
import re
import sys

EXTS = (".cpp", ".cu", ".h", ".cuh", ".hpp")


def blank(text):
    out = []
    i, n = 0, len(text)
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
        elif text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + re.sub(r"[^\n]", " ", text[i + 1 : j - 1]) + c)
            i = j
        elif c == "#" and (i == 0 or text[i - 1] == "\n"):
            j = text.find("\n", i)
            while j > 0 and text[j - 1] == "\\":
                j = text.find("\n", j + 1)
            j = n if j < 0 else j
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


HEAD = re.compile(
    r"\)\s*(const\s*)?(noexcept\s*)?(override\s*)?(final\s*)?(->\s*[\w:<>,\s\*&]+)?$"
    r"|\)\s*:\s*[\s\S]*$"  # constructor initialiser list (checked further below)
)


def functions(path):
    text = blank(open(path, encoding="utf-8", errors="replace").read())
    stack = []  # entries: ("fn", start_line, name) or ("scope", ...)
    results = []
    line = 1
    last_stmt_start = 0
    for i, c in enumerate(text):
        if c == "\n":
            line += 1
        elif c == "{":
            in_fn = any(kind == "fn" for kind, *_ in stack)
            head = text[last_stmt_start:i].strip()
            kind = "block"
            if not in_fn:
                is_fn = False
                if re.search(r"\)\s*(const\s*)?(noexcept\s*)?(override\s*)?(final\s*)?(->\s*[\w:<>,\s\*&]+)?$", head):
                    is_fn = True
                elif re.search(r"\)\s*:\s*\w", head) and not re.match(r"\s*(class|struct|enum)\b", head):
                    is_fn = True  # constructor with initialiser list
                if is_fn and not re.search(r"\b(namespace|class|struct|enum|union)\b[^()]*$", head.split("(")[0] + " "):
                    m = re.search(r"([\w:~]+)\s*\([^()]*", head)
                    name = m.group(1) if m else "?"
                    kind = "fn"
                    stack.append(("fn", line, name))
                    last_stmt_start = i + 1
                    continue
            stack.append((kind, line, ""))
            last_stmt_start = i + 1
        elif c == "}":
            if stack:
                kind, start, name = stack.pop()
                if kind == "fn":
                    results.append((name, start, line, line - start + 1))
            last_stmt_start = i + 1
        elif c == ";":
            last_stmt_start = i + 1
    return results


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--limit", type=int, default=150)
    ap.add_argument("paths", nargs="+")
    args = ap.parse_args()
    found = []
    for p in args.paths:
        files = []
        if os.path.isdir(p):
            for root, _, names in os.walk(p):
                files += [os.path.join(root, f) for f in names if f.endswith(EXTS)]
        else:
            files.append(p)
        for f in sorted(files):
            for name, start, end, length in functions(f):
                if length > args.limit:
                    found.append((length, f, start, name))
    for length, f, start, name in sorted(found, reverse=True):
        print(f"{length:5d}  {f}:{start}  {name}")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
