"""One vocabulary: an option means one thing in every command that takes it, every count
option states and enforces its range, and every ``--help`` lists the exit statuses
(``docs/vocabulary.md`` is the table; this test holds it to the parsers)."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import pytest

from synth.cli import build_parser, main
from synth.cli.vocabulary import QUIET_HELP, QUIET_HELPS
from synth.limits import MAX_TOP

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = (("plan",), ("rank",), ("score",), ("sim",), ("db", "build"), ("db", "info"),
            ("db", "top"), ("db", "export"))


def _parser(*words: str) -> argparse.ArgumentParser:
    parser = build_parser()
    for word in words:
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = sub.choices[word]
    return parser


def _options(*words: str) -> dict[str, argparse.Action]:
    return {s: a for a in _parser(*words)._actions for s in a.option_strings}


@pytest.mark.parametrize("words", [(), ("db",), *COMMANDS], ids=lambda w: " ".join(w) or "-")
def test_every_help_lists_the_exit_statuses(words: tuple[str, ...]) -> None:
    text = " ".join(_parser(*words).format_help().split())
    assert "exit status: 0 " in text, words
    for status in ("; 1 ", "; 2 bad input", "; 3 internal error"):
        assert status in text, (words, status)


def test_shared_options_have_one_help_text() -> None:
    """``--quiet``, ``--json``, ``--out``, ``--mu``, ``--edges``, ``--table``, ``--grip``,
    ``--mass``: the same words wherever they appear (only what is printed or written
    differs)."""
    helps: dict[str, set[str]] = {}
    for words in COMMANDS:
        for name, action in _options(*words).items():
            text = re.sub(r"write .* to this file", "write X to this file", action.help or "")
            text = re.sub(r"print .* as one JSON", "print X as one JSON", text)
            helps.setdefault(name, set()).add(text)
    # --quiet: one meaning, results and errors only; each command says what it silences
    assert helps["--quiet"] == set(QUIET_HELPS.values()) and QUIET_HELPS["plan"] == QUIET_HELP
    for h in helps["--quiet"]:
        assert re.match(r"print (the results and )?errors only( \([^)]*\))?: no ", h), h
    assert len({h.replace(" (the document --out writes)", "").replace("; implies --quiet", "")
                for h in helps["--json"]}) == 1, helps["--json"]
    for name in ("--edges", "--table", "--grip", "--mass", "--density", "--sim-grip",
                 "--surface"):
        assert len({h.replace("candidate ", "grasp ") for h in helps[name]}) == 1, \
            (name, helps[name])
    for h in helps["--mu"]:  # one meaning, a default that depends on the command
        assert h.startswith("Coulomb friction coefficient") or h.startswith("simulate with"), h
    for h in helps["--out"]:
        assert "whole or not at all" in h or "database file" in h, h


def test_each_quiet_says_what_its_command_silences() -> None:
    """The --quiet help of score, rank, sim and db export was plan's, copied: "a plan's table
    ... progress bar ... tallies of candidates by status" where there is none of them."""
    for words in COMMANDS:
        command = " ".join(words)
        opts = _options(*words)
        if "--quiet" in opts:
            assert opts["--quiet"].help == QUIET_HELPS[command], command
    assert "plan" not in QUIET_HELPS["score"] + QUIET_HELPS["rank"] + QUIET_HELPS["sim"]
    assert "progress" not in QUIET_HELPS["score"] + QUIET_HELPS["rank"] + QUIET_HELPS[
        "db export"]
    assert "tall" not in QUIET_HELPS["score"] + QUIET_HELPS["sim"] + QUIET_HELPS["db export"]
    assert "tally of candidates by status" in QUIET_HELPS["rank"]
    assert "table" not in QUIET_HELPS["db export"] + QUIET_HELPS["db build"]


def test_json_implies_quiet_only_where_there_is_one() -> None:
    """db info and db top have no --quiet, and their --json said "implies --quiet"."""
    for words in COMMANDS:
        opts = _options(*words)
        if "--json" in opts:
            assert ("implies --quiet" in opts["--json"].help) == ("--quiet" in opts), words
    assert "--quiet" not in _options("db", "top") and "--json" in _options("db", "top")


def test_json_is_a_switch_everywhere() -> None:
    for words in COMMANDS:
        opts = _options(*words)
        if "--json" in opts:
            assert opts["--json"].nargs == 0 and opts["--json"].metavar is None, words
    assert "--json ]" not in _parser("score").format_usage()


@pytest.mark.parametrize("words, listing", [(("plan",), False), (("db", "build"), False),
                                            (("rank",), True), (("score",), True),
                                            (("db", "top"), True)])
def test_top_states_its_range(words: tuple[str, ...], listing: bool) -> None:
    text = " ".join(_options(*words)["--top"].help.split())
    assert f"1 to {MAX_TOP:,}" in text, text
    assert ("0 for all" in text) == listing, text


@pytest.mark.parametrize("argv", [
    ["rank", "{mesh}", "{c}", "--top", "99999999"],
    ["rank", "{mesh}", "{c}", "--top", "-1"],
    ["score", "{c}", "--top", "1001"],
    ["plan", "{mesh}", "--top", "0", "--no-files"],
    ["plan", "{mesh}", "--top", "1001", "--no-files"],
    ["db", "top", "{c}", "x", "--top", "1001"],
    ["rank", "{mesh}", "{c}", "--mass", "-1"],
    ["plan", "{mesh}", "--samples", "0", "--gripper", "franka", "--units", "m", "--no-files"],
    ["plan", "{mesh}", "--density", "0", "--no-files"],
])
def test_counts_out_of_range_are_refused_by_name(argv: list[str], tmp_path: Path, capsys
                                                 ) -> None:
    c = tmp_path / "c.json"
    c.write_text("[]")
    words = [a.format(mesh=ROOT / "meshes" / "cube.stl", c=c) for a in argv]
    assert main(words) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    option = next(w for w in argv if w.startswith("--") and w != "--no-files"
                  and w not in ("--gripper", "--units"))
    assert option in err and "expected" in err, err


def test_a_file_name_after_json_points_to_out(tmp_path: Path, capsys) -> None:
    c = tmp_path / "c.json"
    c.write_text("[]")
    for argv in (["score", str(c), "--json", str(tmp_path / "s.json")],
                 ["rank", str(ROOT / "meshes" / "cube.stl"), str(c), "--json",
                  str(tmp_path / "r.json")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "--json takes no file name" in err and "--out" in err, err
        assert f"(see 'synth {argv[0]} --help')" in err, err  # the command's own help
        assert not (tmp_path / "s.json").exists() and not (tmp_path / "r.json").exists()


def test_the_vocabulary_page_lists_every_option_once() -> None:
    """docs/vocabulary.md has one row per option of every command, with the commands that
    take it."""
    page = (ROOT / "docs" / "vocabulary.md").read_text()
    rows = {m.group(1): m.group(2) for m in
            re.finditer(r"^\| `(-[-\w]+)[^`]*` \|[^|]*\| ([^|]*) \|$", page, re.M)}
    names = re.findall(r"^\| `(-[-\w]+)", page, re.M)
    assert len(names) == len(set(names)), "an option listed twice"
    for words in COMMANDS:
        command = " ".join(words)
        for name in _options(*words):
            if name in ("-h", "--help", "-k"):
                continue
            assert name in rows, f"{name} of synth {command} is not in docs/vocabulary.md"
            listed = {c.strip() for c in rows[name].replace("`", "").split(",")}
            assert command in listed, (name, command, rows[name])
