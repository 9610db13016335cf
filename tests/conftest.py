import os


os.environ.setdefault("MPLBACKEND", "Agg")

import jax
import pytest

import bandopt


bandopt.configure()
jax.config.update("jax_numpy_rank_promotion", "raise")


@pytest.fixture(scope="session")
def shared_dir():
    """`../shared` beside the checkout (test-only data; never read by the package)."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[1].parent / "shared"
    if not path.is_dir():
        pytest.skip("../shared is not beside this checkout")
    return path


@pytest.fixture(autouse=True)
def _model_cache(tmp_path_factory, monkeypatch):
    """Each test's fitted-estimator cache in its own fresh folder: a test
    never reads a fit another test stored (one may have monkeypatched the
    fit) and never writes into the user's cache."""
    monkeypatch.setenv("BANDOPT_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
