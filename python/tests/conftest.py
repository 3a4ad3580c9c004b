"""Shared fixtures: a session, and the felt CLI where one is built (for comparisons)."""

import os
import pathlib
import shutil

import pytest

import felt

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture
def session():
    return felt.Session()


@pytest.fixture
def felt_cli():
    """The `felt` binary: $FELT_BIN, else one built in the repository, else on PATH."""
    candidates = [os.environ.get("FELT_BIN")]
    candidates += [str(ROOT / "target" / p / "felt") for p in ("release", "debug")]
    candidates.append(shutil.which("felt"))
    for candidate in candidates:
        if candidate and os.access(candidate, os.X_OK):
            return candidate
    pytest.skip("no felt binary built; build it with `cargo build` to compare with the CLI")
