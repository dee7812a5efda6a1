#!/usr/bin/env python3
"""Functions longer than N lines (default 100) in Rust sources outside
tests, by brace matching from each `fn` line to its closing brace (the
`#[cfg(test)]` module of a file and `tests/` folders are skipped).

usage: scripts/long_functions.py [DIR (default host-tools/src)] [--over N]
prints: lines  file  first-line  name   (longest first; nothing if none)
"""
import pathlib
import re
import sys

FN = re.compile(r"\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?fn\s+(\w+)")


def long_functions(root, over):
    found = []
    for path in pathlib.Path(root).rglob("*.rs"):
        if "tests" in path.parts:
            continue
        lines = path.read_text().split("\n")
        i = 0
        while i < len(lines):
            if re.match(r"\s*#\[cfg\(test\)\]", lines[i]):
                break
            m = FN.match(lines[i])
            if not m:
                i += 1
                continue
            depth, started, j = 0, False, i
            while j < len(lines):
                depth += lines[j].count("{") - lines[j].count("}")
                started = started or "{" in lines[j]
                if started and depth <= 0:
                    break
                if not started and lines[j].rstrip().endswith(";"):
                    break
                j += 1
            if j - i + 1 > over:
                found.append((j - i + 1, str(path), i + 1, m.group(6)))
            i = j + 1 if started else i + 1
    return sorted(found, reverse=True)


def main():
    args = sys.argv[1:]
    over = 100
    if "--over" in args:
        k = args.index("--over")
        over = int(args[k + 1])
        del args[k : k + 2]
    root = args[0] if args else "host-tools/src"
    for n, path, line, name in long_functions(root, over):
        print(n, path, line, name)


if __name__ == "__main__":
    main()
