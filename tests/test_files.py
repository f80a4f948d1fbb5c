"""Result files are written whole or not at all (synth.files)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from synth.errors import OutputError
from synth.files import atomic_path, atomic_paths, write_atomic, writing


def test_write_atomic_writes_text_bytes_and_through_a_writer(tmp_path: Path) -> None:
    assert write_atomic(tmp_path / "a.json", "{}\n").read_text() == "{}\n"
    assert (write_atomic(tmp_path / "b.bin", b"\x00\x01")).read_bytes() == b"\x00\x01"
    seen = []

    def writer(p: Path) -> None:
        seen.append(p.suffix)
        p.write_text("x")

    assert write_atomic(tmp_path / "c.png", writer).read_text() == "x"
    assert seen == [".png"]  # writers that choose a format by suffix see the target's suffix
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.bin", "c.png"]


def test_a_failing_writer_leaves_the_old_file_and_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "plan.json"
    target.write_text("old")

    def half_then_crash(p: Path) -> None:
        p.write_text("half a fi")
        raise RuntimeError("disk gone")

    with pytest.raises(RuntimeError):
        write_atomic(target, half_then_crash)
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["plan.json"]


def test_missing_folder_is_an_output_error_naming_the_target(tmp_path: Path) -> None:
    target = tmp_path / "no" / "such" / "plan.json"
    with pytest.raises(OutputError, match="plan.json"):
        write_atomic(target, "{}")
    assert not target.parent.exists()


def test_written_files_get_the_mode_open_would_give(tmp_path: Path) -> None:
    mask = os.umask(0o022)
    try:
        out = write_atomic(tmp_path / "x.json", "{}")
        plain = tmp_path / "y.json"
        plain.write_text("{}")
    finally:
        os.umask(mask)
    assert out.stat().st_mode & 0o777 == plain.stat().st_mode & 0o777 == 0o644


def test_replacing_a_directory_is_an_output_error(tmp_path: Path) -> None:
    (tmp_path / "out.json").mkdir()
    with pytest.raises(OutputError, match="out.json"):
        with atomic_path(tmp_path / "out.json") as tmp:
            tmp.write_text("{}")
    assert (tmp_path / "out.json").is_dir() and len(list(tmp_path.iterdir())) == 1


def test_a_set_is_replaced_only_when_every_file_is_written(tmp_path: Path) -> None:
    a, b = tmp_path / "x.json", tmp_path / "x.png"
    a.write_text("old a")
    b.write_text("old b")
    with pytest.raises(OutputError, match="x.png"):  # the error names the file that failed
        with atomic_paths([a, b]) as (ta, tb):
            with writing(a):
                ta.write_text("new a")
            with writing(b):
                raise OSError(28, "No space left on device")
    assert (a.read_text(), b.read_text()) == ("old a", "old b")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.json", "x.png"]
    with atomic_paths([a, b]) as (ta, tb):
        ta.write_text("new a")
        tb.write_text("new b")
    assert (a.read_text(), b.read_text()) == ("new a", "new b")


def test_an_error_writing_the_first_file_of_a_set_names_the_first(tmp_path: Path) -> None:
    """With one context per file, the innermost (last) would have claimed every error."""
    a, b, c = tmp_path / "x.json", tmp_path / "x.png", tmp_path / "x.glb"
    with pytest.raises(OutputError, match="x.json"):
        with atomic_paths([a, b, c]):
            with writing(a):
                raise OSError(28, "No space left on device")
    assert not list(tmp_path.iterdir())
