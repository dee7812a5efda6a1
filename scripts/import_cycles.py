#!/usr/bin/env python3
"""List import circles between the Rust source files of the workspace.

A circle is a set of files each of which reaches the others through `use`
statements or `crate::`/`super::` paths in code. A folder's `mod.rs` (and a
crate's `lib.rs`/`main.rs`) stands for the folder and is left out: an arrow
to or from it is not counted. Most of them only declare their children and
re-export them, but not all: `fit/mod.rs` defines `Fitted` and `Details`,
which every trainer uses and which name every trainer's report, a circle
this script does not see (docs/architecture.md).

Usage: scripts/import_cycles.py [CRATE_SRC_DIR ...]   (default: every crate's src/)
Exit status 1 when a circle exists, so CI can keep the count at zero.
"""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_CRATES = ["model-core", "firmware", "host-tools", "max31865", "python"]
FOLDER_FILES = {"mod.rs", "lib.rs", "main.rs"}

USE_RE = re.compile(r"\buse\s+([^;]+);", re.S)
PATH_RE = re.compile(r"\b((?:crate|super|self)(?:::[A-Za-z_][A-Za-z0-9_]*)+)")


def strip_comments(text):
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r'"(?:\\.|[^"\\])*"', '""', text)


def cut_tests(text):
    """Drop `#[cfg(test)] mod ... { ... }` blocks: tests are not the house."""
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+\w+\s*\{", text):
        if m.start() < i:
            continue
        out.append(text[i : m.start()])
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def expand(tree):
    """`a::{b, c::{d, e}}` -> ['a::b', 'a::c::d', 'a::c::e']."""
    tree = re.sub(r"\s+", "", tree)
    brace = tree.find("{")
    if brace < 0:
        return [re.sub(r"as\w+$", "", tree)]
    prefix, body = tree[:brace], tree[brace + 1 : tree.rfind("}")]
    parts, depth, start = [], 0, 0
    for k, ch in enumerate(body):
        depth += {"{": 1, "}": -1}.get(ch, 0)
        if ch == "," and depth == 0:
            parts.append(body[start:k])
            start = k + 1
    parts.append(body[start:])
    return [p for part in parts if part for p in expand(prefix + part)]


def module_of(src, path):
    rel = path.relative_to(src).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return parts


def resolve(mod, path):
    """Absolute module path segments of a `crate::`/`super::`/`self::` path."""
    segs = path.split("::")
    if segs[0] == "crate":
        return segs[1:]
    base = list(mod)
    while segs and segs[0] in ("super", "self"):
        if segs.pop(0) == "super":
            base = base[:-1]
    return base + segs


def build_graph(src):
    files = {tuple(module_of(src, p)): p for p in src.rglob("*.rs")}
    edges = {}
    for key, path in files.items():
        is_folder_file = path.name in FOLDER_FILES
        text = cut_tests(strip_comments(path.read_text()))
        paths = [p for m in USE_RE.finditer(text) for p in expand(m.group(1))]
        paths += PATH_RE.findall(text)
        for p in paths:
            if not p.startswith(("crate::", "super::", "self::")):
                continue
            target = longest_module(files, resolve(list(key), p))
            if target is None or target == key:
                continue
            if is_folder_file or files[target].name in FOLDER_FILES:
                continue
            edges.setdefault(key, set()).add(target)
    return files, edges


def longest_module(files, segs):
    for n in range(len(segs), -1, -1):
        if tuple(segs[:n]) in files:
            return tuple(segs[:n])
    return None


def circles(edges):
    """Strongly connected components of more than one file (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in list(edges):
        if v not in index:
            visit(v)
    return out


def main():
    dirs = [Path(a) for a in sys.argv[1:]] or [ROOT / c / "src" for c in DEFAULT_CRATES]
    found = 0
    for src in dirs:
        if not src.is_dir():
            continue
        files, edges = build_graph(src)
        for comp in circles(edges):
            found += 1
            names = [str(files[c].relative_to(ROOT)) for c in comp]
            print(f"circle: {', '.join(names)}")
            for a in comp:
                for b in sorted(edges.get(a, ()) & set(comp)):
                    print(f"  {files[a].relative_to(ROOT)} -> {files[b].relative_to(ROOT)}")
    print(f"{found} import circle(s)", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
