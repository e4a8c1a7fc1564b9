"""Shared fixtures: the real data folder, and one headless OpenGL context for the session."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

# every frame a recording would have stood in for is drawn and its GL calls compared with the
# recording's instead (mane.render.frame_replay): a frame that depends on something missing from
# the recording's key fails the test that drew it
os.environ.setdefault("MANE_REPLAY_VERIFY", "1")

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data``; tests that use it skip when it is absent (a user's fresh clone)."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real hair data not found at {SHARED_DATA} (it sits beside the repo in CI)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def gl():
    """The shared headless OpenGL 4.3+ context (Mesa llvmpipe on CPU machines)."""
    from mane.gpu import get_context

    return get_context()
