"""One step of `fsivsp run`'s VTU output on a large-ish 3D mesh: wall time and file size (docs/commands.md, "ParaView").

The fields of `output.scheme_fields` (velocity P2, pressure P1, the stress tensor, von Mises, displacement, region)
with random values (so that zlib cannot shrink them below real data), written once by `output.VTKSeries` as
`fsivsp run` writes them (VTKOutput, then meshio's rewrite with the region cell array), per-cell points and
``continuous``. One thread. Writes vtu_output.json next to this file.

    python benchmarks/vtu_output.py [LEVELS]     # refinements of the 3D fluid_in_solid mesh (default 2)
"""
import json
import sys
import tempfile
import time
from pathlib import Path

import ngsolve as ngs
import numpy as np

from fsivsp.geometry import build_geometry, refined
from fsivsp.io import VTKSeries, region_cf, symmetric_tensor

ngs.SetNumThreads(1)


def random_field(space) -> ngs.GridFunction:
    field = ngs.GridFunction(space)
    field.vec.FV().NumPy()[:] = np.random.default_rng(0).standard_normal(len(field.vec))
    return field


def fields(mesh) -> dict:
    velocity = random_field(ngs.VectorH1(mesh, order=2))
    stress = random_field(ngs.L2(mesh, order=0, definedon=mesh.Materials("solid")) ** 9)
    sigma = ngs.CF(stress, dims=(3, 3))
    return {"velocity": velocity, "pressure": random_field(ngs.H1(mesh, order=1)),
            "stress": symmetric_tensor(sigma, 3), "von_mises": ngs.sqrt(ngs.InnerProduct(sigma, sigma)),
            "displacement": mesh.MaterialCF({"solid": 1}, default=0) * velocity, "region": region_cf(mesh)}


def measure(mesh, continuous: bool) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        series = VTKSeries(folder, mesh, fields(mesh), continuous=continuous)
        start = time.perf_counter()
        path = series.write(0.0, 0)
        return {"continuous": continuous, "seconds": time.perf_counter() - start, "bytes": path.stat().st_size}


def main(levels: int = 2) -> dict:
    mesh = refined(build_geometry("fluid_in_solid", 3), levels, project=False)
    record = {"cells": mesh.ne, "vertices": mesh.nv, "writes": [measure(mesh, False), measure(mesh, True)]}
    (Path(__file__).with_suffix(".json")).write_text(json.dumps(record, indent=2) + "\n")
    return record


if __name__ == "__main__":
    print(json.dumps(main(*map(int, sys.argv[1:])), indent=2))
