"""Shared fixtures of the Python tests: where the source tree, the build and the command line
are (set by CTest; defaults for a run from the source tree), and small worlds."""

import os
import pathlib

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get(
    "VOXCUT_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
BINARY_DIR = pathlib.Path(os.environ.get("VOXCUT_BINARY_DIR", SOURCE_DIR / "build" / "release"))
CLI = pathlib.Path(os.environ.get("VOXCUT_CLI", BINARY_DIR / "apps" / "voxcut" / "voxcut"))


@pytest.fixture
def source_dir():
    return SOURCE_DIR


@pytest.fixture
def cli():
    assert CLI.is_file(), f"the voxcut command line is not built: {CLI}"
    return CLI


def pytest_sessionfinish(session, exitstatus):
    # A skipped test is a test that did not run: the suite must run all of them.
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None and reporter.stats.get("skipped") and exitstatus == 0:
        session.exitstatus = 1
