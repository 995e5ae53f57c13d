"""Which backend runs the embedded MPM's steps (config key ``mpm.embedded.backend``), without importing either."""

from __future__ import annotations

BACKENDS = ("auto", "numba", "torch")


def uses_kernels(backend: str, device: str, dtype: str) -> bool:
    """Whether the compiled CPU kernels run the steps: backend numba, or auto on the CPU in float64; ValueError
    naming the key for numba elsewhere."""
    cpu_float64 = device.split(":")[0] == "cpu" and dtype == "float64"
    if backend == "numba" and not cpu_float64:
        raise ValueError(
            f"mpm.embedded.backend = 'numba' runs on the CPU in float64, not device {device!r} in {dtype}: use "
            "backend 'torch' (or 'auto')"
        )
    if backend not in BACKENDS:
        raise ValueError(f"mpm.embedded.backend = {backend!r}: expected one of {BACKENDS}")
    return backend == "numba" or (backend == "auto" and cpu_float64)
