#!/usr/bin/env python3
"""The import graph of `src/`: no circle between modules, no import up the
layers of docs/ARCHITECTURE.md.

A module is a file. An edge A -> B is a path in A (a `use`, or a
`crate::`/`super::`/`self::` path in the code) that names an item of B.
A parent's paths into its own children are not edges: a `mod.rs` declares
its children and re-exports their items, it does not depend on them the way
a sibling does. Everything else counts, tests included.

`python3 docs/check_imports.py` prints each circle and each upward edge
and exits 1 if there is one; `--graph` prints every edge.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SRC = ROOT / "src"

# the layers, lowest first (docs/ARCHITECTURE.md): a module may import from
# its own layer and the ones below it
LAYERS = [
    ["realtime"],
    ["error", "operators"],
    ["identification", "beam", "feedforward", "control"],
    ["io"],
    ["suite"],
    ["fmi"],
    ["isolation"],
    ["cli", "main", "lib"],
]


def module_of(path: Path) -> tuple[str, ...]:
    rel = path.relative_to(SRC).with_suffix("")
    parts = rel.parts
    if parts[-1] == "mod":
        parts = parts[:-1]
    if parts == ("lib",) or parts == ("main",):
        return parts
    return tuple(parts)


def strip_comments(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r'"(?:\\.|[^"\\])*"', '""', text)
    return re.sub(r"//[^\n]*", "", text)


def inline_depth(text: str) -> list[tuple[int, int]]:
    """The spans of the inline modules (`mod tests { … }`) of a file."""
    spans = []
    for m in re.finditer(r"\bmod\s+\w+\s*\{", text):
        depth, i = 0, m.end() - 1
        while i < len(text):
            if text[i] == "{":
                depth += 1
            elif text[i] == "}":
                depth -= 1
                if depth == 0:
                    break
            i += 1
        spans.append((m.end(), i))
    return spans


def use_paths(text: str) -> list[list[str]]:
    """Every path a file names: the trees of its `use` items flattened, and
    the `crate::`, `super::` and `self::` paths elsewhere in its code. A
    path inside an inline module starts with one `self` per module, so
    that its `super` means the file's module."""
    paths: list[list[str]] = []
    spans = inline_depth(text)

    def inside(pos: int) -> int:
        return sum(1 for a, b in spans if a <= pos < b)

    def expand(prefix: list[str], tree: str) -> None:
        tree = tree.strip()
        if not tree:
            return
        m = re.match(r"^([\w:]*?)(::)?\{(.*)\}$", tree, flags=re.S)
        if m and tree.endswith("}"):
            head = [p for p in m.group(1).split("::") if p]
            depth, item, items = 0, "", []
            for ch in m.group(3):
                if ch == "{":
                    depth += 1
                elif ch == "}":
                    depth -= 1
                if ch == "," and depth == 0:
                    items.append(item)
                    item = ""
                else:
                    item += ch
            items.append(item)
            for it in items:
                expand(prefix + head, it)
            return
        tree = re.sub(r"\s+as\s+\w+$", "", tree)
        paths.append(prefix + [p for p in tree.split("::") if p])

    for m in re.finditer(r"\buse\s+([^;]+);", text):
        before = len(paths)
        expand([], m.group(1))
        depth = inside(m.start())
        for i in range(before, len(paths)):
            paths[i] = nest(paths[i], depth)
    for m in re.finditer(r"\b((?:crate|super|self)(?:::\w+)+)", text):
        paths.append(nest(m.group(1).split("::"), inside(m.start())))
    return paths


def nest(path: list[str], depth: int) -> list[str]:
    """`path` as written `depth` inline modules deep, from the file's
    module: each leading `super` leaves one inline module; a path that
    stays inside one names its own items."""
    if depth == 0 or path[:1] == ["crate"]:
        return path
    rest = list(path)
    while depth and rest[:1] == ["super"]:
        rest = rest[1:]
        depth -= 1
    if depth:
        return []
    return ["self"] + rest


def resolve(here: tuple[str, ...], is_dir_module: bool, path: list[str],
            modules: set[tuple[str, ...]]) -> tuple[str, ...] | None:
    # `here` is the module; its `super` is its parent
    if not path:
        return None
    if path[0] == "crate":
        base: tuple[str, ...] = ()
        rest = path[1:]
    elif path[0] in ("super", "self"):
        base = here
        rest = path
        while rest and rest[0] in ("super", "self"):
            if rest[0] == "super":
                base = base[:-1]
            rest = rest[1:]
    else:
        # a path from a child declared here (`use step::x`) or an extern crate
        base = here
        rest = path
        if (here + (path[0],)) not in modules:
            return None
    best = base if base in modules else None
    cur = base
    for p in rest:
        cur = cur + (p,)
        if cur in modules:
            best = cur
        else:
            break
    return best


def layer(module: tuple[str, ...]) -> int | None:
    for i, names in enumerate(LAYERS):
        if module[0] in names:
            return i
    return None


def main() -> int:
    files = sorted(SRC.rglob("*.rs"))
    modules = {module_of(f) for f in files}
    modules.add(())
    edges: dict[tuple[str, ...], set[tuple[str, ...]]] = {}
    for f in files:
        here = module_of(f)
        if here in (("lib",), ("main",)):
            continue
        text = strip_comments(f.read_text())
        for path in use_paths(text):
            to = resolve(here, f.name == "mod.rs", path, modules)
            if to is None or to == () or to == here:
                continue
            # a parent into its own children: declaration and facade
            if to[: len(here)] == here:
                continue
            edges.setdefault(here, set()).add(to)
    if "--graph" in sys.argv:
        for a in sorted(edges):
            for b in sorted(edges[a]):
                print("::".join(a), "->", "::".join(b))
    bad = 0
    # upward edges between layers
    for a in sorted(edges):
        for b in sorted(edges[a]):
            la, lb = layer(a), layer(b)
            if la is not None and lb is not None and lb > la:
                print(f"upward import: {'::'.join(a)} -> {'::'.join(b)}")
                bad += 1
    # circles: strongly connected components of more than one module, and
    # of one that reaches its own ancestor and back
    index: dict = {}
    low: dict = {}
    stack: list = []
    on: set = set()
    counter = [0]
    comps: list[list[tuple[str, ...]]] = []

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                strong(w)
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
                comps.append(comp)

    sys.setrecursionlimit(10000)
    for v in sorted(modules):
        if v not in index:
            strong(v)
    for comp in comps:
        names = sorted("::".join(c) for c in comp)
        print("import circle: " + " <-> ".join(names))
        inside = set(comp)
        for a in sorted(comp):
            for b in sorted(edges.get(a, ())):
                if b in inside:
                    print(f"    {'::'.join(a)} -> {'::'.join(b)}")
        bad += 1
    if bad:
        return 1
    print(f"{len(modules) - 1} modules, {sum(len(v) for v in edges.values())} imports: "
          "no circle, nothing upward")
    return 0


if __name__ == "__main__":
    sys.exit(main())
