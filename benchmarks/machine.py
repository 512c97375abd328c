"""The machine: time of one sparse matrix-vector product per stored entry against the matrix's size.

A 3D vector Laplacian (continuous P1, NGSolve's ``SparseMatrixd``) on a uniformly refined unit cube: the cost per
nonzero of the product that every iteration of the iterative solver is made of. Where it grows with the size,
the machine's memory bandwidth falls with the working set, and a time per step divided by one product of the
same size (benchmarks/scale.py) is what the algorithm itself adds.

    python benchmarks/machine.py --json benchmarks/machine.json
"""
from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path


def measure(levels: range) -> list[dict]:
    import ngsolve as ngs
    from netgen.csg import unit_cube

    from fsivsp.geometry import refined

    base = ngs.Mesh(unit_cube.GenerateMesh(maxh=0.25))
    rows = []
    for level in levels:
        mesh = refined(base, level, False)
        space = ngs.VectorH1(mesh, order=1)
        u, v = space.TnT()
        form = ngs.BilinearForm(space)
        form += ngs.InnerProduct(ngs.Grad(u), ngs.Grad(v)) * ngs.dx
        matrix = form.Assemble().mat.DeleteZeroElements(0.0)
        x, y = matrix.CreateColVector(), matrix.CreateColVector()
        x[:] = 1.0
        entries = len(matrix.CSR()[0])
        repeats = max(3, int(2e8 / entries))
        y.data = matrix * x
        start = time.perf_counter()
        for _ in range(repeats):
            y.data = matrix * x
        seconds = (time.perf_counter() - start) / repeats
        rows.append({"level": level, "rows": matrix.height, "entries": entries, "bytes": 12 * entries,
                     "seconds": seconds, "ns_per_entry": seconds / entries * 1e9})
        print(f"level {level}: {matrix.height:>9} rows {entries:>11} entries ({12 * entries / 2**20:7.1f} MiB)  "
              f"{seconds * 1e3:8.2f} ms = {seconds / entries * 1e9:5.2f} ns per entry", flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", default="2-5", help="refinement levels A-B of the unit cube (maxh 0.25)")
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    low, high = (int(x) for x in args.levels.split("-"))
    rows = measure(range(low, high + 1))
    if args.json:
        from fsivsp.io.atomic import write_json
        write_json(args.json, {"machine": platform.platform(), "processor": platform.processor(), "rows": rows})


if __name__ == "__main__":
    main()
