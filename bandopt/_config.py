"""Process-wide JAX settings: CPU, float64, persistent compilation cache."""

import os
from pathlib import Path


CACHE_MIN_COMPILE_S = 0.0
"""Every compiled program goes into the persistent cache, however quick its
compilation (JAX's `jax_persistent_cache_min_compile_time_secs`). A fitted
inversion compiles ~200 small programs (score chunks, posterior summaries,
photometry per prior size), each under 0.5 s but 8 s together; with the old
threshold of 0.5 s they were compiled again by every run. Measured with
`bandopt evaluate` on one lamp file, a warm cache each time: 39 s a run at
0.5 s, 26 s at 0 (the cache: ~200 files, 4 MB)."""


def configure(*, x64: bool = True, cache_dir: str | os.PathLike | None = None) -> None:
    """Put JAX on the CPU in float64 with the compilation cache on.

    Call once at the start of a program (the CLI, experiments and tests do).
    The cache lives in `$BANDOPT_JAX_CACHE` or `~/.cache/bandopt/jax`.
    """
    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    # jax only here: JAX_PLATFORMS must be set first, and `import bandopt`
    # stays free of JAX (start-up time)
    import jax

    jax.config.update("jax_enable_x64", x64)
    if cache_dir is None:
        cache_dir = os.environ.get(
            "BANDOPT_JAX_CACHE", Path.home() / ".cache" / "bandopt" / "jax"
        )
    Path(cache_dir).mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(cache_dir))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", CACHE_MIN_COMPILE_S)
