"""Shared fixtures of the Python module's tests: the CLI to compare with, the repository's files,
an output folder in the build tree (SHADEFIT_TEST_OUTPUT), never /tmp or the source tree."""

import json
import os
import pathlib
import subprocess

import pytest

import shadefit

ROOT = pathlib.Path(__file__).resolve().parents[2]
CYCLES = ROOT / "reference_images" / "cycles"
SCENE = ROOT / "tests" / "data" / "sphere_key.toml"


def _cli_path():
    path = os.environ.get("SHADEFIT_CLI", str(ROOT / "build" / "studies" / "shadefit"))
    if not os.access(path, os.X_OK):
        pytest.fail(f"the shadefit executable is needed to compare with: {path} (set SHADEFIT_CLI)")
    return path


@pytest.fixture(scope="session")
def cli():
    """cli(*args) -> CompletedProcess of the shadefit executable (text, never raises)."""
    path = _cli_path()

    def run(*args, cwd=None):
        return subprocess.run([path, *map(str, args)], capture_output=True, text=True, cwd=cwd)

    return run


@pytest.fixture(scope="session")
def cli_json(cli):
    def run(*args):
        done = cli(*args)
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    return run


def cli_error(done):
    """The one-line message of a failed CLI run, without its 'shadefit: error: ' prefix."""
    assert done.returncode != 0, done.stdout
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    prefix = "shadefit: error: "
    assert lines[0].startswith(prefix), lines[0]
    return lines[0][len(prefix):]


@pytest.fixture
def out(request):
    """A fresh folder under the build tree's test_output/python/<test name>."""
    base = pathlib.Path(os.environ.get("SHADEFIT_TEST_OUTPUT", ROOT / "build" / "test_output" / "python"))
    path = base / request.node.name.replace("[", "_").replace("]", "")
    if path.exists():
        import shutil
        shutil.rmtree(path)
    path.mkdir(parents=True)
    return path


def open_fds():
    return len(os.listdir("/proc/self/fd"))
