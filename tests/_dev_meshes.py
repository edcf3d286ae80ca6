"""The development meshes next to the repository (``../shared/meshes``), where they are."""

from __future__ import annotations

from pathlib import Path

import pytest

#: ``../shared/meshes`` beside the repository's folder.
DEV = Path(__file__).resolve().parents[2] / "shared" / "meshes"
#: Skips a test where the development meshes are not there (a clone on its own).
needs_dev = pytest.mark.skipif(not DEV.is_dir(), reason="../shared/meshes is not there")
