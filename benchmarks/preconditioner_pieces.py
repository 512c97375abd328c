"""The iterative solver's pieces: the time of one application of each against the level.

The 3D fluid ball of examples/fluid_in_solid_3d.toml (MINI; as `benchmarks/scale.py`, no error norms), uniformly refined; for each level the
median of ``--repeats`` applications of: the step matrix, the velocity block (`multigrid.TwoLevel`), its vertex
block's V-cycle, one forward and one backward Gauss–Seidel sweep, the pressure block (`schur`). Each piece is a
fixed sequence of sparse operations, linear in N: what it costs more per unknown on a finer level is the machine.

    python benchmarks/preconditioner_pieces.py --levels 3-4 --json benchmarks/preconditioner_pieces.json
"""
from __future__ import annotations

import argparse
from pathlib import Path

from scale import median_seconds   # benchmarks/scale.py, next to this script

EXAMPLE = Path(__file__).parent.parent / "examples" / "fluid_in_solid_3d.toml"


def pieces(level: int, repeats: int) -> dict:
    import numpy as np

    from fsivsp.case import load_study_case
    from fsivsp.geometry import refined
    from fsivsp.scheme import Scheme
    from fsivsp.spaces import build_spaces
    from fsivsp.study import dirichlet_boundaries, manufactured_data

    case = load_study_case(EXAMPLE)
    mesh = refined(case.coarse_mesh(), level, case.discretisation.project_refinement)
    dirichlet = dirichlet_boundaries(mesh)
    data = manufactured_data(case.exact, case.materials, dirichlet, case.discretisation.initial_stress, case.discretisation.initial_velocity)
    scheme = Scheme(build_spaces(mesh, case.discretisation.family, case.discretisation.order, dirichlet), case.materials, data, case.dt,
                    solver=case.with_solver(method="iterative").solver)
    matrix, preconditioner = scheme.solver.matrix, scheme.solver.preconditioner
    velocity = preconditioner.velocity
    x = matrix.CreateColVector()
    x.FV().NumPy()[:] = np.sin(np.arange(len(x)))
    y = x.CreateVector()
    vertex_in = velocity.gather.CreateColVector()
    vertex_in.data = velocity.gather * x
    vertex_out = vertex_in.CreateVector()

    def product(operator, into, vector):
        def apply():
            into.data = operator * vector
        return apply

    seconds = {
        "step matrix": median_seconds(product(matrix, y, x), repeats),
        "velocity block": median_seconds(product(velocity, y, x), repeats),
        "vertex V-cycle": median_seconds(product(velocity.coarse, vertex_out, vertex_in), repeats),
        "Gauss-Seidel forward": median_seconds(lambda: velocity.smoother.forward(y, x), repeats),
        "Gauss-Seidel backward": median_seconds(lambda: velocity.smoother.backward(y, x), repeats),
        "pressure block": median_seconds(product(preconditioner.schur, y, x), repeats),
    }
    return {"level": level, "dofs": scheme.spaces.free_dofs(), "preconditioner": preconditioner.describe(),
            "seconds": seconds}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", default="3-4", help="refinement levels A-B")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    low, high = (int(x) for x in args.levels.split("-"))
    rows = []
    for level in range(low, high + 1):
        row = pieces(level, args.repeats)
        rows.append(row)
        print(f"level {level} ({row['dofs']} unknowns): " + ", ".join(
            f"{name} {s * 1e3:.1f} ms" for name, s in row["seconds"].items()), flush=True)
    for a, b in zip(rows, rows[1:]):
        ratio = b["dofs"] / a["dofs"]
        print(f"per unknown, level {b['level']} / level {a['level']}: " + ", ".join(
            f"{name} {b['seconds'][name] / a['seconds'][name] / ratio:.2f}" for name in a["seconds"]))
    if args.json:
        from fsivsp.report import write_json
        write_json(args.json, rows)


if __name__ == "__main__":
    main()
