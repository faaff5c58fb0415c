#!/usr/bin/env python3
"""Run the guide: every code block of README.md and docs/guide/, as written.

For each page (README.md, then the chapters in SUMMARY.md's order) a fresh
temporary directory holds links to the repository's top-level entries, and
the page's blocks run there in order, so a later block sees the files an
earlier one wrote and nothing lands in the repository:

  sh, bash   run with `bash -euo pipefail`; `mfcbeam` is target/release's
             binary, `cargo run --release -- ARGS` runs it too, and any other
             `cargo` command runs in the repository (it builds what CI built)
  python     run with python3 (the installed `mfcbeam` package)
  rust       compiled and run as doctests: the page must be included in
             src/lib.rs's doctests (checked here, run by `cargo test`)
  toml       parsed
  text, json, csv
             output or a format, shown and not run

An HTML comment on the line before a fence says more about the block:

  <!-- writes: A B -->     the files A and B exist and are not empty after it
  <!-- exit: 2 -->        its expected exit status (default 0)
  <!-- save: app.c -->    not run: its text is saved as app.c for the blocks
                          after it (a C program the next block compiles)
  <!-- file: PATH -->     not run: its text is part of the repository's PATH
                          (a program shown in full runs from there)
  <!-- ci -->             not run here: every command in it is a line of
                          .ci/run, which runs it (the test command itself)
  <!-- table: FILE without COLUMN -->
                          before a markdown table, not a block: the table
                          is the one in FILE (written by a block of the
                          page) cell for cell, COLUMN (a header, optional:
                          a wall-clock time, say) left out of both
  <!-- draws: OUT=FIGURE -->
                          the SVG it writes as OUT is the committed FIGURE
                          (a path in the repository) up to a pixel in
                          coordinates, its text exact: the pictures of the
                          README and the guide are what the code draws now

With --update-figures the figures are written over instead of compared
(after a change that is meant to change them; commit the result).

It also checks the links: every relative link or image of a page points to
a file that exists (inside docs/guide/ for a chapter, so the built book
has it), an anchor to a heading that exists, and SUMMARY.md lists every
chapter. Exit 1 on the first failure with the page, line and output.

The pages run side by side, one per core (`--jobs N` for another count):
each has its own directory, and nearly every block keeps one core busy.
A page's lines are printed when it and every page before it are done, in
the pages' order.

Usage: python3 docs/check_guide.py [--links-only] [--update-figures] [--jobs N] [PAGE ...]
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
GUIDE = REPO / "docs" / "guide"
SHOWN = {"text", "json", "csv"}
FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
NOTE = re.compile(r"^<!--\s*(writes|exit|save|file|ci|draws)\s*:?\s*(.*?)\s*-->\s*$")
TABLE = re.compile(r"^<!--\s*table:\s*(\S+)(?:\s+without\s+(.+?))?\s*-->\s*$")
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)\)")


class Failure(Exception):
    pass


def pages():
    summary = (GUIDE / "SUMMARY.md").read_text()
    chapters = re.findall(r"\]\(([^)]+\.md)\)", summary)
    on_disk = sorted(p.name for p in GUIDE.glob("*.md") if p.name != "SUMMARY.md")
    missing = sorted(set(on_disk) - set(chapters))
    if missing:
        raise Failure(f"docs/guide/SUMMARY.md does not list {missing}")
    for c in chapters:
        if not (GUIDE / c).is_file():
            raise Failure(f"docs/guide/SUMMARY.md lists {c}, which does not exist")
    return [REPO / "README.md"] + [GUIDE / c for c in chapters]


def expanded(path):
    """The page as the book shows it: {{#include F}} replaced by F."""
    text = path.read_text()

    def include(m):
        return (path.parent / m.group(1)).read_text()

    return re.sub(r"\{\{#include ([^}]+)\}\}", include, text)


def slug(heading):
    """A heading's anchor, as mdBook and GitHub make it."""
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def anchors(text):
    out, fence = set(), False
    for line in text.splitlines():
        if FENCE.match(line):
            fence = not fence
        elif not fence and line.startswith("#"):
            out.add(slug(line.lstrip("#")))
    return out


def check_links(path):
    text = expanded(path)
    fence = False
    for n, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            fence = not fence
        if fence:
            continue
        for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
            if re.match(r"^[a-z]+:", target):
                continue
            file, _, anchor = target.partition("#")
            dest = (path.parent / file).resolve() if file else path
            where = f"{path.relative_to(REPO)}:{n}: link {target}"
            if not dest.exists():
                raise Failure(f"{where}: no such file")
            if path.parent == GUIDE and GUIDE not in dest.parents and dest != GUIDE:
                raise Failure(f"{where}: outside docs/guide/, so not in the book")
            if anchor and dest.suffix == ".md" and anchor not in anchors(expanded(dest)):
                raise Failure(f"{where}: no heading with anchor #{anchor}")


def blocks(path):
    """(line, language, notes, text) of each fenced block."""
    lines = expanded(path).splitlines()
    out, k = [], 0
    while k < len(lines):
        m = FENCE.match(lines[k])
        if not m:
            k += 1
            continue
        indent, lang = m.group(1), m.group(2).split(",")[0]
        start = k + 1
        notes, j = {}, k - 1
        while j >= 0 and NOTE.match(lines[j].strip()):
            key, value = NOTE.match(lines[j].strip()).groups()
            notes[key] = value
            j -= 1
        k += 1
        body = []
        # a fence in a list item is indented; its text is the same less that
        while k < len(lines) and lines[k].strip() != "```":
            line = lines[k]
            body.append(line[len(indent):] if line.startswith(indent) else line)
            k += 1
        if k == len(lines):
            raise Failure(f"{path.relative_to(REPO)}:{start}: unclosed code block")
        out.append((start, lang, notes, "\n".join(body) + "\n"))
        k += 1
    return out


def tables(path):
    """(line, file, column left out, rows) of each table marked as a file's."""
    lines = expanded(path).splitlines()
    out = []
    for k, line in enumerate(lines):
        m = TABLE.match(line.strip())
        if not m:
            continue
        rows, j = [], k + 1
        while j < len(lines) and lines[j].strip().startswith("|"):
            rows.append(lines[j])
            j += 1
        if not rows:
            raise Failure(f"{path.relative_to(REPO)}:{k + 1}: a table note without a table")
        out.append((k + 1, m.group(1), m.group(2), rows))
    return out


def cells(rows, without, required=True):
    """A markdown table's cells, row by row, the column `without` dropped
    (and the separator row); the page may leave that column out itself."""
    grid = [[c.strip() for c in r.strip().strip("|").split("|")] for r in rows]
    grid = [r for r in grid if not all(set(c) <= set("-: ") for c in r)]
    if without and without not in grid[0] and not required:
        return grid
    if without:
        if without not in grid[0]:
            raise Failure(f"no column '{without}' in {grid[0]}")
        k = grid[0].index(without)
        grid = [r[:k] + r[k + 1:] for r in grid]
    return grid


def workspace():
    d = Path(tempfile.mkdtemp(prefix="mfcbeam-guide-"))
    for entry in REPO.iterdir():
        if entry.name != ".git":
            (d / entry.name).symlink_to(entry)
    shim = d / ".bin"
    shim.mkdir()
    cargo = shutil.which("cargo")
    (shim / "cargo").write_text(
        "#!/usr/bin/env bash\n"
        "# the guide's `cargo run --release -- ARGS` is the built program\n"
        'if [ "${1:-}" = run ] && [ "${2:-}" = --release ] && [ "${3:-}" = -- ]; then\n'
        '  shift 3; exec mfcbeam "$@"\n'
        "fi\n"
        f'cd "{REPO}" && exec "{cargo}" "$@"\n'
    )
    (shim / "cargo").chmod(0o755)
    env = dict(os.environ)
    env["PATH"] = f"{shim}:{REPO / 'target' / 'release'}:{env['PATH']}"
    return d, env


def same_svg(new, old):
    """Why the SVG `new` is not the drawing `old` (None: it is). Numbers
    inside tags (coordinates) may differ by one pixel, which the last bit of
    a computed value can decide; text and structure must be equal."""
    split = re.compile(r"(<[^>]*>)")
    number = re.compile(r"(-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)")
    a, b = split.split(new), split.split(old)
    if len(a) != len(b):
        return f"{len(a)} parts against {len(b)}"
    for x, y in zip(a, b):
        if not x.startswith("<"):
            if x != y:
                return f"text {x.strip()[:60]!r} against {y.strip()[:60]!r}"
            continue
        xs, ys = number.split(x), number.split(y)
        if len(xs) != len(ys) or xs[0::2] != ys[0::2]:
            return f"tag {x[:80]!r} against {y[:80]!r}"
        for u, v in zip(xs[1::2], ys[1::2]):
            if abs(float(u) - float(v)) > 1.0:
                return f"{u} against {v} in {x[:80]!r}"
    return None


def ci_lines():
    text = (REPO / ".ci" / "run").read_text()
    return {" ".join(line.split()) for line in text.splitlines()}


def commands(text):
    """The block's commands: comments dropped, continued lines joined."""
    joined = re.sub(r"\\\n\s*", " ", text)
    for line in joined.splitlines():
        line = re.sub(r"\s+#.*$", "", line).strip()
        for part in line.split("&&"):
            part = " ".join(part.split())
            if part and not part.startswith("#"):
                yield part


def run_page(path, links_only, say=print):
    """Run one page's blocks; `say` gets its progress lines."""
    rel = path.relative_to(REPO)
    check_links(path)
    found = blocks(path)
    if any(lang == "rust" for _, lang, _, _ in found):
        lib = (REPO / "src" / "lib.rs").read_text()
        if f'include_str!("../{rel}")' not in lib:
            raise Failure(f"{rel} has Rust blocks but src/lib.rs does not doctest it")
    if links_only:
        return 0
    d, env = workspace()
    ran = 0
    try:
        for line, lang, notes, text in found:
            where = f"{rel}:{line}"
            if "file" in notes:
                shown = (REPO / notes["file"]).read_text()
                if text not in shown:
                    raise Failure(f"{where}: the block is not the text of {notes['file']}")
                continue
            if "save" in notes:
                (d / notes["save"]).write_text(text)
                continue
            if "ci" in notes:
                ci = ci_lines()
                for c in commands(text):
                    if not any(c in line for line in ci):
                        raise Failure(f"{where}: `{c}` is not run by .ci/run")
                continue
            if lang in SHOWN or lang == "rust":
                continue
            if lang == "toml":
                try:
                    tomllib.loads(text)
                except tomllib.TOMLDecodeError as e:
                    raise Failure(f"{where}: {e}")
                continue
            if lang in ("sh", "bash"):
                argv = ["bash", "-euo", "pipefail", "-c", text]
            elif lang == "python":
                argv = ["python3", "-c", text]
            else:
                raise Failure(f"{where}: a ```{lang or '(no language)'} block: name one of "
                              "sh, python, rust, toml, text, json, csv, or mark it")
            t0 = time.monotonic()
            p = subprocess.run(argv, cwd=d, env=env, capture_output=True, text=True,
                               timeout=900)
            want = int(notes.get("exit", "0"))
            say(f"  {where}: {lang}, exit {p.returncode}, {time.monotonic() - t0:.1f} s")
            if p.returncode != want:
                raise Failure(f"{where}: exit {p.returncode}, expected {want}\n"
                              f"--- block\n{text}--- stdout\n{p.stdout[-4000:]}"
                              f"--- stderr\n{p.stderr[-4000:]}")
            for f in notes.get("writes", "").split():
                if not (d / f).is_file() or (d / f).stat().st_size == 0:
                    raise Failure(f"{where}: it claims to write {f}, which is missing or empty")
            for pair in notes.get("draws", "").split():
                out, _, figure = pair.partition("=")
                drawn, committed = d / out, REPO / figure
                if not drawn.is_file():
                    raise Failure(f"{where}: it claims to draw {out}, which is missing")
                if UPDATE:
                    shutil.copyfile(drawn, committed)
                    say(f"  updated {figure}")
                    continue
                why = same_svg(drawn.read_text(), committed.read_text())
                if why:
                    raise Failure(f"{where}: {out} is not {figure} ({why}); if the change "
                                  "is meant, run with --update-figures")
            ran += 1
        for line, name, without, rows in tables(path):
            where = f"{rel}:{line}"
            written = d / name
            if not written.is_file():
                raise Failure(f"{where}: the table is {name}'s, which no block wrote")
            try:
                ours = cells(rows, without, required=False)
                theirs = cells([r for r in written.read_text().splitlines()
                                if r.strip().startswith("|")], without)
            except Failure as e:
                raise Failure(f"{where}: {e}")
            if ours != theirs:
                k = next((i for i, (a, b) in enumerate(zip(ours, theirs)) if a != b),
                         min(len(ours), len(theirs)))
                a = ours[k] if k < len(ours) else "(no row)"
                b = theirs[k] if k < len(theirs) else "(no row)"
                raise Failure(f"{where}: the table is not {name}'s: row {k}: {a} against {b}")
    finally:
        shutil.rmtree(d, ignore_errors=True)
    return ran


UPDATE = False


def run_logged(page, links_only):
    """One page in a worker: its lines, and the count of blocks or the
    failure that stopped it."""
    lines = [f"{page.relative_to(REPO)}"]
    try:
        return lines, run_page(page, links_only, say=lines.append)
    except (Failure, subprocess.TimeoutExpired) as e:
        return lines, e


def jobs(argv):
    if "--jobs" in argv:
        k = argv.index("--jobs")
        if k + 1 >= len(argv) or not argv[k + 1].isdigit() or int(argv[k + 1]) < 1:
            raise Failure("--jobs takes a count of at least 1")
        return int(argv[k + 1]), argv[:k] + argv[k + 2:]
    # the cores this process may run on (Linux), else the machine's
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0))), argv
    return os.cpu_count() or 1, argv


def main(argv):
    global UPDATE
    try:
        workers, argv = jobs(argv)
        UPDATE = "--update-figures" in argv
        links_only = "--links-only" in argv
        wanted = [a for a in argv if not a.startswith("--")]
        chosen = [p for p in pages()
                  if not wanted or any(p.name == Path(w).name for w in wanted)]
    except Failure as e:
        print(f"check_guide: {e}", file=sys.stderr)
        return 1
    total = 0
    with ThreadPoolExecutor(max_workers=workers) as pool:
        running = [pool.submit(run_logged, page, links_only) for page in chosen]
        for future in running:
            lines, result = future.result()
            print("\n".join(lines), flush=True)
            if isinstance(result, Exception):
                for f in running:
                    f.cancel()
                print(f"check_guide: {result}", file=sys.stderr)
                return 1
            total += result
    print(f"check_guide: every page's links resolve; {total} blocks ran as written")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
