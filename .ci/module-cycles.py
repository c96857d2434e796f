#!/usr/bin/env python3
"""No import cycle between the files of one crate (issue #22).

For every crate under crates/*/src, builds the graph "file A names an item of file B" from
`crate::` and `super::` paths in non-test, non-comment code and fails when the graph has a cycle
(a strongly connected component of more than one file). Parent/child modules (a file and the
files of its own directory) are not edges: a module re-exporting its children is not a cycle.
Written by hand because cargo-modules needs a nightly toolchain CI does not install.
"""
import glob
import os
import re
import sys


def modules(src):
    mods = {}
    for f in glob.glob(os.path.join(src, "**", "*.rs"), recursive=True):
        rel = os.path.relpath(f, src)[:-3]
        name = rel.replace("/mod", "").replace("/", "::")
        if name in ("lib", "main"):
            continue
        text = open(f, encoding="utf-8").read().split("#[cfg(test)]")[0]
        mods[name] = "\n".join(l for l in text.split("\n") if not l.strip().startswith("//"))
    return mods


def edges(name, text, mods):
    out = set()
    parent = name.split("::")[:-1]
    paths = ["::".join(p.split("::")) for p in re.findall(r"crate::((?:\w+::)*\w+)", text)]
    for sup in re.findall(r"\bsuper::((?:\w+::)*\w+)", text):
        paths.append("::".join(parent[:-1] + sup.split("::")) if parent else sup)
    for path in paths:
        parts = path.split("::")
        for k in range(len(parts), 0, -1):
            target = "::".join(parts[:k])
            if target in mods:
                related = target == name or target.startswith(name + "::") or name.startswith(target + "::")
                if not related:
                    out.add(target)
                break
    return out


def cycles(graph):
    index, low, stack, on, found, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
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
                found.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def main():
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "crates")
    bad = 0
    for src in sorted(glob.glob(os.path.join(root, "*", "src"))):
        mods = modules(src)
        graph = {m: edges(m, t, mods) for m, t in mods.items()}
        for comp in cycles(graph):
            crate = os.path.basename(os.path.dirname(src))
            print(f"crates/{crate}: import cycle between {', '.join(comp)}")
            bad += 1
    print("module cycles: none" if not bad else f"module cycles: {bad}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
