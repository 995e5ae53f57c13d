"""The MPM kernel's time per step on a captured state, and variants of it timed against it side by side.

    python benchmarks/kernel_step.py                                  # the shipped kernel at 0.5 m
    python benchmarks/kernel_step.py --variants my_kernels.py ...     # each variant against it

Runs case 1's realization 0 at ``--cells`` for ``--frames`` frames through the solver, keeps the kernels' state
at the last frame, then advances copies of it by ``--steps`` steps with the shipped ``advance_frame`` and with each
variant module's (a copy of ``rgns/engines/mpm/kernels.py`` edited; same signature), alternating, ``--trials``
times. Prints each one's best microseconds per step (the best of many short trials is what survives a shared
host's interference; a whole realization's time moves by ±15 % between runs) and its ratio to the shipped kernel,
and the largest difference of any particle array from the shipped kernel's after the steps (0.0: bit-identical).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from dataclasses import asdict
from pathlib import Path
from types import ModuleType

import numpy as np
import torch

from rgns.config import load_config
from rgns.engines.batch import run_mpm
from rgns.engines.mpm import frame_kernels
from rgns.engines.mpm import kernels as shipped
from rgns.engines.settings import MpmSettings
from rgns.montecarlo.runs import CaseInputs
from rgns.scene.realizations import accurate_case_inputs, draw_realization

REPO = Path(__file__).resolve().parents[1]


def captured_state(cells: float, frames: int) -> tuple[frame_kernels.FrameKernels, list[np.ndarray], float]:
    """The kernels' bridge, copies of the particle arrays and the time step at the last of ``frames`` frames."""
    config = load_config(REPO / "config" / "config.yaml")
    inputs = CaseInputs.from_params(asdict(accurate_case_inputs(config, "case1", cells)))
    captured: dict = {}
    advance = frame_kernels.FrameKernels.advance

    def capture(self, particles, substeps, dt):
        captured["state"] = (self, [view.copy() for view in self.views(particles)], dt[0])
        return advance(self, particles, substeps, dt)

    frame_kernels.FrameKernels.advance = capture  # type: ignore[method-assign]
    try:
        run_mpm([draw_realization(inputs, 0)], MpmSettings.from_config(config["mpm"]), frames, keep="ends")
    finally:
        frame_kernels.FrameKernels.advance = advance  # type: ignore[method-assign]
    return captured["state"]


def load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None, path
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module  # numba finds an inlined function's module by name
    spec.loader.exec_module(module)
    return module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cells", type=float, default=0.5)
    parser.add_argument("--frames", type=int, default=40)
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--trials", type=int, default=30)
    parser.add_argument("--variants", type=Path, nargs="*", default=[])
    args = parser.parse_args()
    torch.set_num_threads(1)
    bridge, arrays, dt = captured_state(args.cells, args.frames)
    starts = np.array([0, len(arrays[0])], dtype=np.int64)
    kernels = {"shipped": shipped} | {str(path): load(path) for path in args.variants}

    def advance(module: ModuleType) -> tuple[float, list[np.ndarray]]:
        state = [array.copy() for array in arrays]
        bridge._kernels = module  # FrameKernels' own call, on this module's advance_frame
        began = time.perf_counter()
        bridge._advance(tuple(state), starts, [args.steps], [dt])
        return time.perf_counter() - began, state

    reference = advance(shipped)[1]  # compiles (or loads) each first
    differences = {
        name: max(float(np.max(np.abs(a - b))) for a, b in zip(advance(m)[1], reference)) for name, m in kernels.items()
    }
    best = dict.fromkeys(kernels, float("inf"))
    for _ in range(args.trials):
        for name, module in kernels.items():
            best[name] = min(best[name], advance(module)[0])
    print(
        f"{len(arrays[0]):,} particles at {args.cells:g} m, frame {args.frames}, {args.steps} steps, best of {args.trials}"
    )
    for name, seconds in best.items():
        print(
            f"{name}: {seconds / args.steps * 1e6:.1f} µs a step, {best['shipped'] / seconds:.3f}x the shipped kernel, "
            f"largest difference from it {differences[name]:.1e}"
        )


if __name__ == "__main__":
    main()
