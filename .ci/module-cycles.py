#!/usr/bin/env python3
"""No import cycle between the files of one crate.

For every crate under crates/*/src, builds the graph "file A names an item of file B" from
`crate::` and `super::` paths (brace groups expanded) in non-test, non-comment code and fails when the graph has a cycle
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


def expand(tree):
    """The paths of a use-tree body (`a::{b, c::{d, e}}` → a::b, a::c::d, a::c::e)."""
    tree = re.sub(r"\s+", "", tree)
    out = []
    m = re.match(r"((?:\w+::)*)\{(.*)\}$", tree)
    if not m:
        return [tree.rstrip(":")] if tree else []
    prefix, body = m.group(1), m.group(2)
    parts, depth, cur = [], 0, ""
    for ch in body:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    for p in parts:
        if p in ("", "self"):
            if prefix:
                out.append(prefix.rstrip(":"))
            continue
        out.extend(prefix + q for q in expand(p))
    return out


def use_trees(text, anchor):
    """Each `anchor::…` path in the text, with brace groups followed to their closing brace."""
    trees = []
    for m in re.finditer(r"\b" + anchor + r"::", text):
        i, depth = m.end(), 0
        while i < len(text):
            ch = text[i]
            if ch == "{":
                depth += 1
            elif ch == "}":
                if depth == 0:
                    break
                depth -= 1
            elif not (ch.isalnum() or ch in "_:" or (depth and ch in ", \n\t")):
                break
            i += 1
        trees.append(text[m.end():i])
    return trees


def edges(name, text, mods):
    """Files this module names. `super::` in module a::b means a; each further `super::` one more
    level up; in a top-level module it means the crate root."""
    out = set()
    here = name.split("::")
    paths = [p for t in use_trees(text, "crate") for p in expand(t)]
    for t in use_trees(text, "super"):
        ups = 1
        while t.startswith("super::"):
            t, ups = t[len("super::"):], ups + 1
        base = here[:-ups] if ups <= len(here) else []
        paths.extend("::".join(base + p.split("::")) for p in expand(t))
    for path in paths:
        parts = [p for p in path.split("::") if p]
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


def self_test():
    """A planted cycle through `super::` and a brace group must be found; a tree without one not."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        src = os.path.join(d, "src")
        os.makedirs(os.path.join(src, "io"))
        files = {
            "lib.rs": "mod io;\n",
            "io/mod.rs": "mod reader;\nmod writer;\n",
            "io/reader.rs": "use super::{writer::Writer, other};\npub struct Reader;\n",
            "io/writer.rs": "use super::reader::Reader;\npub struct Writer;\n",
        }
        for rel, text in files.items():
            with open(os.path.join(src, rel), "w") as f:
                f.write(text)
        mods = modules(src)
        found = cycles({m: edges(m, t, mods) for m, t in mods.items()})
        assert found == [["io::reader", "io::writer"]], found
        with open(os.path.join(src, "io/writer.rs"), "w") as f:
            f.write("pub struct Writer;\n")
        mods = modules(src)
        found = cycles({m: edges(m, t, mods) for m, t in mods.items()})
        assert found == [], found
    print("module cycles self-test: a planted cycle is caught, none reported without it")


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
    if sys.argv[1:] == ["--self-test"]:
        self_test()
        sys.exit(0)
    sys.exit(main())
