"""A stand-in for CB-Geo's ``mpm`` in tests where the real binary is absent.

It takes the same arguments (-f DIR/ -i JSON -p N), reads the case with rgns's case reader,
and writes ``particles<step>.h5`` tables of the same layout (the fields rgns reads): every
particle slides 1 cm per stored frame. ``FAKE_MPM_ABORT=<realization index>`` makes that
realization abort the way CB-Geo does when a particle leaves the mesh.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import h5py
import numpy as np

from rgns.engines.cbgeo.case import read_case

FIELDS = [
    ("id", "<u8"),
    ("mass", "<f8"),
    ("volume", "<f8"),
    ("coord_x", "<f8"),
    ("coord_y", "<f8"),
    ("material_id", "<u4"),
    ("svars_0", "<f8"),
]


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("-f", dest="directory", required=True)
    parser.add_argument("-i", dest="input", default="mpm.json")
    parser.add_argument("-p", dest="threads", default="1")
    args = parser.parse_args()
    case = read_case(args.directory)
    print(
        f"fake mpm: {len(case.positions)} particles, {args.threads} thread(s), "
        f"OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY', '')}"
    )
    if os.environ.get("FAKE_MPM_ABORT") == str(case.meta["index"]):
        print("mpm::base::init_particles() Particle outside the mesh domain", flush=True)
        return 134
    analysis = case.config["analysis"]
    output_steps = case.config["post_processing"]["output_steps"]
    out = Path(args.directory) / case.config["post_processing"]["path"] / analysis["uuid"]
    out.mkdir(parents=True, exist_ok=True)
    digits = len(str(analysis["nsteps"]))
    order = np.arange(len(case.positions))[::-1]  # CB-Geo does not promise id order: readers must sort
    friction = np.radians(case.binned_friction_deg)
    for frame, step in enumerate(range(0, analysis["nsteps"], output_steps)):
        table = np.zeros(len(order), dtype=FIELDS)
        table["id"] = order
        table["coord_x"] = case.positions[order, 0] + 0.01 * frame
        table["coord_y"] = case.positions[order, 1]
        table["volume"] = case.volumes[order]
        table["mass"] = case.volumes[order] * case.density_kg_m3[order]
        table["material_id"] = case.material_id[order]
        table["svars_0"] = friction[order]
        with h5py.File(out / f"particles{step:0{digits}d}.h5", "w") as handle:
            handle.create_dataset("table", data=table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
