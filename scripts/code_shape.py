#!/usr/bin/env python3
"""The shape checks of the restructuring (issue 34), over the workspace's Rust sources:

  scripts/code_shape.py [--max-fn 150] [--max-file 800]

- functions longer than --max-fn lines (from the `fn` line to its closing brace; tests,
  benches and examples included, `#[cfg(test)]` modules too);
- files in src/ (the root package) longer than --max-file lines;
- import cycles between the files of one crate: an edge A -> B for every `use crate::m`
  (or `super::m`, `self::m` from a folder module) in A naming B's module path. Cycles
  through the crate root are ignored (it re-exports), and `pub use` re-exports are not
  imports of code.
- error variants that repeat their cause: a `thiserror` variant whose source is marked
  (`#[source]`, `#[from]`, or a field named `source`) and whose `#[error(...)]` message
  also prints it (`{0}` or `{source}`); the CLI prints the chain, so the cause would show
  twice (ARCHITECTURE.md, "Errors keep their cause").

Exit status 1 when anything is found.
"""
import argparse
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def rust_files():
    for base, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in ("target", ".git", "shared") and not d.startswith(".")]
        for f in files:
            if f.endswith(".rs"):
                yield os.path.join(base, f)


def strip(line):
    # Drop string literals and line comments, roughly, for brace counting.
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])'", "''", line)
    return line.split("//")[0]


def long_functions(path, limit):
    lines = open(path, encoding="utf-8").read().split("\n")
    out = []
    i = 0
    fn_re = re.compile(r"^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?(extern\s+\"C\"\s+)?fn\s+(\w+)")
    while i < len(lines):
        m = fn_re.match(lines[i])
        if not m:
            i += 1
            continue
        name = m.group(7)
        depth = 0
        started = False
        j = i
        while j < len(lines):
            s = strip(lines[j])
            if not started and ";" in s and "{" not in s:
                break  # a declaration without a body
            depth += s.count("{") - s.count("}")
            if "{" in s:
                started = True
            if started and depth <= 0:
                break
            j += 1
        n = j - i + 1
        if started and n > limit:
            out.append((n, name, i + 1))
        i += 1
    return out


def crate_of(path):
    rel = os.path.relpath(path, ROOT)
    parts = rel.split(os.sep)
    if parts[0] == "crates":
        return os.path.join(ROOT, "crates", parts[1], "src")
    if parts[0] == "src":
        return os.path.join(ROOT, "src")
    return None


def module_path(src, path):
    rel = os.path.relpath(path, src)[:-3].split(os.sep)
    if rel[-1] in ("lib", "main", "mod"):
        rel = rel[:-1]
    return tuple(rel)


def import_cycles():
    found = []
    crates = {}
    for f in rust_files():
        src = crate_of(f)
        if src and f.startswith(src + os.sep):
            crates.setdefault(src, []).append(f)
    for src, files in sorted(crates.items()):
        mods = {module_path(src, f): f for f in files}
        leaf = {m for m, f in mods.items() if os.path.basename(f) not in ("lib.rs", "main.rs")}
        edges = {m: set() for m in mods}
        for m, f in mods.items():
            text = open(f, encoding="utf-8").read()
            text = re.sub(r"#\[cfg\(test\)\]\s*mod tests\s*\{.*", "", text, flags=re.S)
            # `pub use` re-exports shape the module tree; they are not imports of code.
            for u in re.finditer(r"(?<!pub )(?<!pub\(crate\) )\buse\s+(crate|super|self)::([\w:{}, *\n]+);", text):
                head, rest = u.group(1), u.group(2)
                base = () if head == "crate" else (m[:-1] if head == "super" and os.path.basename(f) != "mod.rs" else (m[:-1] if head == "super" else m))
                if head == "super" and os.path.basename(f) == "mod.rs":
                    base = m[:-1]
                if head == "self":
                    base = m if os.path.basename(f) in ("mod.rs", "lib.rs", "main.rs") else m[:-1]
                first = re.split(r"[:{},\s]", rest.strip())
                names = [x for x in re.findall(r"[A-Za-z_]\w*", rest)]
                # the longest module prefix named by the path
                path = list(base)
                for part in rest.replace("{", "::{").split("::"):
                    part = part.strip()
                    if not re.fullmatch(r"\w+", part):
                        break
                    if tuple(path + [part]) in mods:
                        path.append(part)
                    else:
                        break
                target = tuple(path)
                if target != m and target in leaf:
                    edges[m].add(target)
                # grouped imports `use crate::{a::X, b::Y}`
                if rest.strip().startswith("{"):
                    for g in re.findall(r"(\w+)::", rest):
                        t = tuple(list(base) + [g])
                        if t in leaf and t != m:
                            edges[m].add(t)
        # cycles by DFS
        colour = {}
        stack = []

        def dfs(v):
            colour[v] = 1
            stack.append(v)
            for w in sorted(edges[v]):
                if colour.get(w) == 1:
                    cyc = stack[stack.index(w):] + [w]
                    found.append((os.path.relpath(src, ROOT), " -> ".join("::".join(c) or "<root>" for c in cyc)))
                elif w not in colour:
                    dfs(w)
            stack.pop()
            colour[v] = 2

        for v in sorted(edges):
            if v not in colour:
                dfs(v)
    return found


ERROR_VARIANT = re.compile(
    r"#\[error\((?P<msg>.*?)\)\]\s*(?:///.*\n\s*|#\[.*?\]\s*)*(?P<name>\w+)\s*(?P<body>\((?:[^()]|\([^()]*\))*\)|\{.*?\n\s*\})",
    re.S,
)


def repeated_causes():
    """Error variants whose message prints the source they also hold."""
    found = []
    for f in rust_files():
        text = open(f, encoding="utf-8").read()
        if "thiserror" not in text:
            continue
        for m in ERROR_VARIANT.finditer(text):
            body, msg = m.group("body"), m.group("msg")
            has_source = "#[from]" in body or "#[source]" in body or re.search(r"\bsource\s*:", body)
            if has_source and ("{0}" in msg or "{source}" in msg):
                line = text[: m.start()].count("\n") + 1
                found.append((os.path.relpath(f, ROOT), line, m.group("name")))
    return found


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-fn", type=int, default=150)
    ap.add_argument("--max-file", type=int, default=800)
    a = ap.parse_args()
    bad = 0
    fns = []
    for f in rust_files():
        for n, name, line in long_functions(f, a.max_fn):
            fns.append((n, os.path.relpath(f, ROOT), line, name))
    for n, f, line, name in sorted(fns, reverse=True):
        print(f"function {name} at {f}:{line}: {n} lines")
        bad += 1
    for f in rust_files():
        rel = os.path.relpath(f, ROOT)
        if rel.startswith("src" + os.sep):
            n = sum(1 for _ in open(f, encoding="utf-8"))
            if n > a.max_file:
                print(f"file {rel}: {n} lines")
                bad += 1
    for src, cyc in import_cycles():
        print(f"import cycle in {src}: {cyc}")
        bad += 1
    for f, line, name in repeated_causes():
        print(f"error variant {name} at {f}:{line}: prints the source it holds")
        bad += 1
    print(f"{bad} finding(s)", file=sys.stderr)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
