import os
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import settings

DATA_DIR = Path(
    os.environ.get(
        "SKLEARN_MESHPH_DATA", Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
    )
)


@pytest.fixture(scope="session")
def sumner_dir():
    """The Sumner meshes, or a clean skip when they are absent."""
    path = DATA_DIR / "sumner"
    if not path.is_dir():
        pytest.skip(f"Sumner data not found at {path} (set SKLEARN_MESHPH_DATA)")
    return path


@pytest.fixture(scope="session")
def icosphere3():
    mesh = trimesh.creation.icosphere(3)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


# CI runs the property tests on a fixed set of examples, so that a run is reproducible;
# locally hypothesis explores new examples every time.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
