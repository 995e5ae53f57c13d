"""Where the MPM kernel's step goes: the shipped kernel against copies of it with one phase switched off each.

    python benchmarks/kernel_phases.py [--cells 0.5] [--trials 15] [--frames 40]

Writes one copy of ``rgns/engines/mpm/kernels.py`` per phase (the weights computed once instead of every step;
the p2g scatter, the strain sum, the stress update, the force scatter or g2p skipped) and times them side by side
with ``benchmarks/kernel_step.py``: a phase's cost is the shipped kernel's µs a step less its copy's. The copies'
answers are wrong by design (the differences it prints are large); only their times mean something.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
KERNELS = REPO / "rgns" / "engines" / "mpm" / "kernels.py"
PHASES = {  # phase: (the shipped line that starts it, the same line switched off)
    "weights": (
        "            outside[b] += _factors(",
        "            if _ == 0:\n                outside[b] += _factors(",
    ),
    "p2g": (
        "    for q in range(count):\n        p = p0 + q\n        particle_mass",
        "    for q in range(0):\n        p = p0 + q\n        particle_mass",
    ),
    "strain": (
        "    for q in range(count):\n        lxx = 0.0",
        "    for q in range(0):\n        lxx = 0.0",
    ),
    "stress": (
        "            _trial_stresses(\n",
        "            yielding[:count] = False\n            if count < 0:\n                _trial_stresses(\n",
    ),
    "force": (
        "    for q in range(count):\n        a, b, t = stress[q",
        "    for q in range(0):\n        a, b, t = stress[q",
    ),
    "g2p": (
        "    for q in range(count):\n        p = p0 + q\n        sum_ax",
        "    for q in range(0):\n        p = p0 + q\n        sum_ax",
    ),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cells", type=float, default=0.5)
    parser.add_argument("--trials", type=int, default=15)
    parser.add_argument("--frames", type=int, default=40, help="the frame whose state is stepped (kernel_step's)")
    args = parser.parse_args()
    source = KERNELS.read_text()
    with tempfile.TemporaryDirectory() as folder:
        variants = []
        for phase, (line, off) in PHASES.items():
            if source.count(line) != 1:
                sys.exit(f"kernel_phases: the {phase} phase's line is no longer in {KERNELS.name}; update PHASES")
            variants.append(Path(folder) / f"without_{phase}.py")
            variants[-1].write_text(source.replace(line, off))
        command = [sys.executable, str(REPO / "benchmarks" / "kernel_step.py"), "--cells", str(args.cells)]
        command += ["--frames", str(args.frames)]
        subprocess.run([*command, "--trials", str(args.trials), "--variants", *map(str, variants)], check=True)


if __name__ == "__main__":
    main()
