"""The ``mane`` console script: version, help, and errors printed without a traceback."""
import subprocess
import sys

import pytest

import mane
from mane.app.cli import COMMANDS, main


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"mane {mane.__version__}"


def test_help_lists_every_command(capsys):
    assert main([]) == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


def test_every_command_module_has_its_interface():
    import importlib

    for name, (module, help_text) in COMMANDS.items():
        mod = importlib.import_module(module)
        assert callable(mod.add_arguments) and callable(mod.run), name
        assert help_text


def test_console_script_reports_errors_without_traceback(tmp_path):
    bad = tmp_path / "broken.hair"
    bad.write_bytes(b"HAIR" + b"\0" * 10)
    proc = subprocess.run([sys.executable, "-m", "mane", "info", str(bad)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert "broken.hair" in proc.stderr


def test_unknown_command_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["no-such-command"])
    assert exc.value.code == 2


@pytest.mark.parametrize("argv, words", [
    (["simulate", "g.tfx", "--frames", "2"], ["mane simulate: error: unrecognized arguments: --frames 2",
                                             "did you mean --max-frames"]),
    (["render", "--sise", "64x64"], ["mane render: error: unrecognized arguments: --sise", "--size"]),
    (["grow", "--out", "g.npz", "--zzz"], ["mane grow: error: unrecognized arguments: --zzz"]),
    (["--frames"], ["mane: error: unrecognized arguments: --frames"]),
])
def test_an_unknown_option_is_named_by_its_command(capsys, argv, words):
    """The command's own usage and prefix (not the top parser's), with the closest options."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    for w in words:
        assert w in last, err
    if argv[0] != "--frames":
        assert f"usage: mane {argv[0]}" in err
