"""Result files are written whole or not at all (synth.files)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from synth.errors import OutputError
from synth.files import atomic_path, write_atomic


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
