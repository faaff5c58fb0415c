"""docs/check_guide.py catches what it is there to catch: a failing block, a
missing file a block claims, a drawing that changed, a broken link or
anchor, a command said to be CI's that CI does not run."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
import check_guide as g  # noqa: E402

SVG = (
    '<svg width="100" height="50">\n'
    '<polyline stroke="#000000" points="10,20 11,21 12,22"/>\n'
    "<text x=\"5\" y=\"6\">0.5</text>\n</svg>\n"
)


def test_a_pixel_of_difference_in_coordinates_is_the_same_drawing():
    assert g.same_svg(SVG, SVG) is None
    moved = SVG.replace("11,21", "12,20")
    assert g.same_svg(moved, SVG) is None


def test_two_pixels_text_or_a_missing_curve_are_another_drawing():
    assert "against" in g.same_svg(SVG.replace("11,21", "13,21"), SVG)
    assert "text" in g.same_svg(SVG.replace(">0.5<", ">0.6<"), SVG)
    fewer = SVG.replace('<polyline stroke="#000000" points="10,20 11,21 12,22"/>\n', "")
    assert g.same_svg(fewer, SVG) is not None
    shorter = SVG.replace(" 12,22", "")
    assert g.same_svg(shorter, SVG) is not None


def test_notes_and_indented_fences_are_read(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "1. a step:\n"
        "   <!-- writes: a.txt -->\n"
        "   <!-- exit: 2 -->\n"
        "   ```sh\n"
        "   echo hi > a.txt\n"
        "   ```\n"
    )
    [(line, lang, notes, text)] = g.blocks(page)
    assert (lang, notes, text) == ("sh", {"writes": "a.txt", "exit": "2"}, "echo hi > a.txt\n")


def test_commands_join_continuations_and_split_chains():
    text = "cargo build --release \\\n  -p x && ./app  # run it\n# a comment\n"
    assert list(g.commands(text)) == ["cargo build --release -p x", "./app"]


def run_page(tmp_path, monkeypatch, text):
    monkeypatch.setattr(g, "REPO", tmp_path)
    monkeypatch.setattr(g, "GUIDE", tmp_path / "docs" / "guide")
    (tmp_path / "docs" / "guide").mkdir(parents=True, exist_ok=True)
    (tmp_path / ".ci").mkdir(exist_ok=True)
    (tmp_path / ".ci" / "run").write_text("cargo test --workspace\n")
    (tmp_path / "src").mkdir(exist_ok=True)
    (tmp_path / "src" / "lib.rs").write_text("")
    page = tmp_path / "README.md"
    page.write_text(text)
    return g.run_page(page, links_only=False)


def test_a_block_that_fails_or_does_not_write_what_it_claims_fails(tmp_path, monkeypatch):
    with pytest.raises(g.Failure, match="exit 3, expected 0"):
        run_page(tmp_path, monkeypatch, "```sh\nexit 3\n```\n")


def test_a_claimed_file_must_be_written(tmp_path, monkeypatch):
    text = "<!-- writes: out.csv -->\n```sh\ntrue\n```\n"
    with pytest.raises(g.Failure, match="claims to write out.csv"):
        run_page(tmp_path, monkeypatch, text)


def test_blocks_share_their_directory_and_an_expected_exit_is_kept(tmp_path, monkeypatch):
    text = (
        "<!-- save: hello.sh -->\n```text\necho saved\n```\n"
        "<!-- writes: out.txt -->\n```sh\nbash hello.sh > out.txt\n```\n"
        "<!-- exit: 2 -->\n```sh\ntest -s out.txt && exit 2\n```\n"
    )
    assert run_page(tmp_path, monkeypatch, text) == 2


def test_a_command_said_to_be_cis_must_be_in_ci(tmp_path, monkeypatch):
    assert run_page(tmp_path, monkeypatch, "<!-- ci -->\n```sh\ncargo test --workspace\n```\n") == 0
    with pytest.raises(g.Failure, match="not run by .ci/run"):
        run_page(tmp_path, monkeypatch, "<!-- ci -->\n```sh\ncargo test --release\n```\n")


def test_rust_blocks_need_the_doctests_and_blocks_need_a_language(tmp_path, monkeypatch):
    with pytest.raises(g.Failure, match="does not doctest it"):
        run_page(tmp_path, monkeypatch, "```rust\nfn main() {}\n```\n")
    with pytest.raises(g.Failure, match="no language"):
        run_page(tmp_path, monkeypatch, "```\nls\n```\n")


def test_broken_links_and_anchors_are_found(tmp_path, monkeypatch):
    with pytest.raises(g.Failure, match="no such file"):
        run_page(tmp_path, monkeypatch, "see [x](nowhere.md)\n")
    (tmp_path / "other.md").write_text("# A title: with `code`\n")
    with pytest.raises(g.Failure, match="no heading"):
        run_page(tmp_path, monkeypatch, "see [x](other.md#missing)\n")
    assert run_page(tmp_path, monkeypatch, "see [x](other.md#a-title-with-code)\n") == 0


def guide(tmp_path, monkeypatch, chapters):
    """A repository with a one-block README and the chapters given."""
    run_page(tmp_path, monkeypatch, "```sh\ntrue\n```\n")
    summary = "".join(f"- [{name}]({name})\n" for name in chapters)
    (tmp_path / "docs" / "guide" / "SUMMARY.md").write_text(summary)
    for name, text in chapters.items():
        (tmp_path / "docs" / "guide" / name).write_text(text)


def test_pages_run_side_by_side_and_print_in_their_order(tmp_path, monkeypatch, capsys):
    # the first chapter waits (up to 5 s) until the second has run, in a
    # directory both pages' workspaces link to: only side by side can it pass
    (tmp_path / "shared").mkdir()
    guide(tmp_path, monkeypatch, {
        "a.md": "```sh\nfor _ in $(seq 50); do test -e shared/b-ran && break; sleep 0.1; done\n"
                "test -e shared/b-ran\n```\n",
        "b.md": "```sh\ntouch shared/b-ran\n```\n",
    })
    assert g.main(["--jobs", "1"]) == 1
    assert "docs/guide/a.md:1: exit 1" in capsys.readouterr().err
    # the second page may have started before the failure cancelled it
    (tmp_path / "shared" / "b-ran").unlink(missing_ok=True)
    assert g.main(["--jobs", "2"]) == 0
    out = capsys.readouterr().out
    assert out.index("docs/guide/a.md") < out.index("docs/guide/b.md") < out.index("3 blocks ran")


def test_a_failing_page_fails_the_run_with_its_line(tmp_path, monkeypatch, capsys):
    guide(tmp_path, monkeypatch, {"a.md": "```sh\ntrue\n```\n", "b.md": "```sh\nexit 4\n```\n"})
    assert g.main(["--jobs", "2"]) == 1
    assert "docs/guide/b.md:1: exit 4, expected 0" in capsys.readouterr().err
    assert g.main(["--jobs", "0"]) == 1
    assert "--jobs takes a count" in capsys.readouterr().err


def test_a_table_marked_as_a_files_is_that_files_table(tmp_path, monkeypatch):
    block = ("<!-- writes: t.md -->\n```sh\nprintf '| a | t (us) |\\n|---|---|\\n"
             "| 1 | 9.5 |\\n' > t.md\n```\n")
    same = "<!-- table: t.md without t (us) -->\n| a | t (us) |\n|---|---|\n| 1 | 3.0 |\n"
    assert run_page(tmp_path, monkeypatch, block + same) == 1
    other = same.replace("| 1 | 3.0 |", "| 2 | 3.0 |")
    with pytest.raises(g.Failure, match="not t.md's: row 1"):
        run_page(tmp_path, monkeypatch, block + other)
    with pytest.raises(g.Failure, match="which no block wrote"):
        run_page(tmp_path, monkeypatch, same)
    # the page may leave the column out; the file must have it
    shorter = "<!-- table: t.md without t (us) -->\n| a |\n|---|\n| 1 |\n"
    assert run_page(tmp_path, monkeypatch, block + shorter) == 1
    with pytest.raises(g.Failure, match="no column 'b'"):
        run_page(tmp_path, monkeypatch, block + shorter.replace("without t (us)", "without b"))
