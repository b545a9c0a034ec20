"""The type stubs (python/shadefit/__init__.pyi) against the module as built: mypy's stubtest
imports shadefit from the build tree (PYTHONPATH) and fails on every name, argument, default
or property the stubs and the module disagree on, and on every public name the module has that
the stubs lack. The differences meant are in stubtest_allowlist.txt, each with its reason.

Needs python3-mypy (scripts/bootstrap.sh installs it in test mode)."""

import os
import pathlib
import shutil
import subprocess
import sys

import pytest

import shadefit

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]
STUBS = ROOT / "python" / "shadefit" / "__init__.pyi"
ALLOWLIST = HERE / "stubtest_allowlist.txt"


def stubtest(stub_text, out_dir):
    """stubtest's (exit status, output) for `stub_text` as shadefit's stubs, against the module
    this test imports."""
    try:
        import mypy.stubtest  # noqa: F401
    except ImportError:
        pytest.fail("stubtest needs python3-mypy (scripts/bootstrap.sh test)")
    stubs = out_dir / "stubs" / "shadefit"
    shutil.rmtree(stubs, ignore_errors=True)
    stubs.mkdir(parents=True)
    (stubs / "__init__.pyi").write_text(stub_text, encoding="utf-8")
    runtime = pathlib.Path(shadefit.__file__).resolve().parents[1]
    env = dict(os.environ, MYPYPATH=str(stubs.parent), PYTHONPATH=str(runtime))
    # mypy's cache goes under the output folder, not the working directory.
    done = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "--allowlist", str(ALLOWLIST), "--concise",
         "--mypy-config-file", str(write_config(out_dir)), "shadefit"],
        capture_output=True, text=True, env=env, cwd=out_dir)
    return done.returncode, done.stdout + done.stderr


def write_config(out_dir):
    config = out_dir / "mypy.ini"
    config.write_text(f"[mypy]\ncache_dir = {out_dir / 'mypy_cache'}\n", encoding="utf-8")
    return config


def test_stubs_match_the_module(out):
    code, output = stubtest(STUBS.read_text(encoding="utf-8"), out)
    assert code == 0, output


def test_a_stub_that_drifts_fails(out):
    """The check can fail: a renamed keyword argument and a function the module lacks."""
    text = STUBS.read_text(encoding="utf-8")
    drifted = text.replace("def read_image(path: PathLike)", "def read_image(file: PathLike)")
    assert drifted != text
    drifted += "\ndef not_in_the_module() -> None: ...\n"
    code, output = stubtest(drifted, out)
    assert code != 0
    assert "shadefit.read_image" in output and "shadefit.not_in_the_module" in output, output
