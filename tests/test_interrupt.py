"""Ctrl-C that a library swallowed is raised again (synth/interrupt.py)."""

from __future__ import annotations

import signal

import pytest

from synth import interrupt
from synth.cli import main
from synth.cli.progress import LineProgress


def test_an_interrupt_swallowed_is_raised_at_the_next_progress_report():
    """trimesh catches BaseException around its optional imports: an interrupt landing there
    is lost to Python, not to synth, whose next progress report raises it again."""
    interrupt.clear()
    try:
        try:
            interrupt.on_interrupt(signal.SIGINT, None)
        except BaseException:  # noqa: BLE001 - what such a library does
            pass
        assert interrupt.pending()
        with pytest.raises(KeyboardInterrupt):
            LineProgress(enabled=False)(0.5, "planning")
    finally:
        interrupt.clear()
    LineProgress(enabled=False)(0.5, "planning")  # handled: nothing to raise


def test_main_restores_the_interrupt_handler(tmp_path, capsys):
    before = signal.getsignal(signal.SIGINT)
    assert main(["score", str(tmp_path / "none.json")]) == 2
    capsys.readouterr()
    assert signal.getsignal(signal.SIGINT) is before and not interrupt.pending()


def test_an_interrupt_while_the_parser_is_built_is_one_line(monkeypatch, capsys):
    """Building the parser imports most of the command line (the first 0.1 s of a command):
    a Ctrl-C there printed Python's traceback and exited by the signal."""
    import synth.cli

    def cut(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(synth.cli, "build_parser", cut)
    assert main(["plan", "meshes/cube.stl"]) == 130
    assert capsys.readouterr().err == "synth: interrupted\n"
    monkeypatch.setattr(interrupt, "install", cut)  # before _main's own try
    assert main(["plan", "meshes/cube.stl"]) == 130
    assert capsys.readouterr().err == "synth: interrupted\n"


def test_an_interrupt_while_the_command_line_loads_is_one_line(monkeypatch, capsys):
    """The console command loads synth.cli inside interrupt.run: a Ctrl-C there (the first
    tens of milliseconds of every command) ends it in one line with status 130, not with
    Python's traceback; and the command then runs as synth.cli.main does."""
    import builtins

    real = builtins.__import__

    def interrupted(name, *args, **kwargs):
        if name == "synth.cli":
            raise KeyboardInterrupt
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", interrupted)
    assert interrupt.run() == 130
    assert capsys.readouterr().err == "synth: interrupted\n"
    monkeypatch.setattr(builtins, "__import__", real)
    monkeypatch.setattr("sys.argv", ["synth", "--version"])
    with pytest.raises(SystemExit) as e:  # argparse's --version exits after printing
        interrupt.run()
    assert e.value.code == 0 and capsys.readouterr().out.startswith("synth ")
