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


MAPS_BEFORE_CLEARING = 20_000
"""Memory maps of this process above which compiled programs are released
after a test module. Every XLA:CPU executable holds tens to hundreds of maps,
and the suite compiles thousands (one per function and shape); the kernel's
limit (vm.max_map_count, 65530 by default) once crashed the compiler with
SIGSEGV two thirds into the suite. Released programs come back from the
persistent compilation cache when a later module needs them."""


def _memory_maps() -> int:
    try:
        with open(f"/proc/{os.getpid()}/maps") as f:
            return sum(1 for _ in f)
    except OSError:  # not Linux: no such limit to watch
        return 0


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    yield
    if _memory_maps() > MAPS_BEFORE_CLEARING:
        import gc

        jax.clear_caches()
        gc.collect()
