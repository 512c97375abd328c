"""Beyond two cores, on paper (docs/mpi.md): the partition and the messages of a distributed run measured under
``mpirun -np N`` (N = 2–5, oversubscribed), extrapolated to 64 and 1024 ranks.

    python benchmarks/mpi_extrapolation.py --ranks 2,3,4,5 --refine 1,2,3 --json benchmarks/mpi_extrapolation.json

For every refinement of the case's mesh and every N, ``mpirun -np N`` runs this file with ``--child``: the mesh
is made and distributed as ``fsivsp run`` does (`parallel.shared_case`), the spaces built (`spaces.build_spaces`),
and every rank counts its cells, its dofs of X_h = V_h × Q_h, its interface unknowns (free dofs that its
``ParallelDofs`` share with another rank), its neighbour ranks and its BDDC wirebasket dofs. Up to
``--messages-up-to`` unknowns the step matrix and the distributed preconditioner are built too (no time step):
BDDC is checked as a solver of its form (one random right-hand side), and the messages every rank sends are
counted by Open MPI's monitoring (``OMPI_MCA_pml_monitoring_enable=2``, read through MPI_T) for one product with
the step matrix, one preconditioner application, one inner product and one MinRes iteration (NGSolve's
MinResSolver run for 15 iterations minus 5, over 10).

The parent fits the interface law and extrapolates to 64 and 1024 ranks (the formulas are printed and stored
with the figures). NGSolve keeps rank 0 free of cells, so N ranks work on P = N − 1 parts.
"""
from __future__ import annotations

import argparse
import ctypes
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: MPI_T variable classes in Open MPI's mpi.h (enum MPI_T_PVAR_CLASS_*).
PVAR_CLASS_SIZE, PVAR_CLASS_COUNTER = 2, 6
#: Open MPI's monitoring counters: per peer (messages and bytes sent) and per communicator (collectives).
COUNTERS = {"messages": ("pml_monitoring_messages_count", PVAR_CLASS_SIZE),
            "bytes": ("pml_monitoring_messages_size", PVAR_CLASS_SIZE),
            "all_to_all": ("coll_monitoring_a2a_count", PVAR_CLASS_COUNTER),
            "one_to_all": ("coll_monitoring_o2a_count", PVAR_CLASS_COUNTER),
            "all_to_one": ("coll_monitoring_a2o_count", PVAR_CLASS_COUNTER)}
#: MinRes iterations of the two counted solves (their difference gives one iteration's messages).
ITERATIONS = (5, 15)

#: Serial MinRes iterations per step against free unknowns (docs/solvers.md: the ball, h1amg/multigrid).
SERIAL_ITERATIONS = ((65_130, 204), (535_830, 249), (1_640_486, 337))
#: Distributed (BDDC) iterations per step, 2 ranks (docs/mpi.md; 3 ranks gave the same 124).
BDDC_ITERATIONS = ((22_944, 99), (197_682, 124))
#: The 2-rank run of 197 682 unknowns (benchmarks/mpi_scaling.json): rank 0's peak (BDDC's coarse factor) and
#: seconds per MinRes iteration (66.3 s per step / 124), nearly all rank 0's coarse solves (serial: 0.055 s).
COARSE_REFERENCE = {"unknowns": 197_682, "gib": 3.42, "seconds_per_iteration": 66.35 / 124}
#: The 2-rank run of 587 262 unknowns was stopped with rank 0 at 21.3 GiB (benchmarks/mpi_scaling_500k.json).
COARSE_STOPPED = {"unknowns": 587_262, "gib": 21.3}
#: Fill of a 3D sparse Cholesky factor (nested dissection): memory and solve work ∝ n^(4/3).
FILL_EXPONENT = 4 / 3
#: Neighbours of a part at many parts (assumed, not measured: with at most 4 parts every part touches every
#: other): a part of a cubic lattice shares dofs with 6 faces, 12 edges and 8 corners.
NEIGHBOURS_MANY_PARTS = 26
STRONG_UNKNOWNS = 2_213_510  # the largest ball of docs/solvers.md
WEAK_UNKNOWNS_PER_RANK = 500_000  # per working rank (part)


# -- measured, under mpirun (--child) -----------------------------------------------------------------------------


class Monitor:
    """This rank's counters of Open MPI's monitoring through MPI_T (ctypes: mpi4py has no MPI_T): messages
    and bytes sent to every rank, and the collective operations in ``comm`` (an mpi4py communicator)."""

    def __init__(self, comm):
        from mpi4py import MPI
        self.lib = ctypes.CDLL("libmpi.so.40")  # Open MPI's, loaded by mpi4py already
        provided, self.session = ctypes.c_int(), ctypes.c_void_p()
        self._check(self.lib.MPI_T_init_thread(0, ctypes.byref(provided)), "MPI_T_init_thread")
        self._check(self.lib.MPI_T_pvar_session_create(ctypes.byref(self.session)), "MPI_T_pvar_session_create")
        bound = ctypes.c_void_p(MPI._handleof(comm))
        self.handles = {}
        for key, (name, kind) in COUNTERS.items():
            index, handle, count = ctypes.c_int(), ctypes.c_void_p(), ctypes.c_int()
            self._check(self.lib.MPI_T_pvar_get_index(name.encode(), kind, ctypes.byref(index)), name)
            self._check(self.lib.MPI_T_pvar_handle_alloc(self.session, index, ctypes.byref(bound),
                                                         ctypes.byref(handle), ctypes.byref(count)), name)
            self.lib.MPI_T_pvar_start(self.session, handle)  # continuous counters need no start (and say so)
            self.handles[key] = handle, count.value

    @staticmethod
    def _check(code: int, what: str) -> None:
        if code:
            raise RuntimeError(f"{what}: MPI_T error {code} (is OMPI_MCA_pml_monitoring_enable=2 set?)")

    def read(self) -> dict[str, np.ndarray]:
        values = {}
        for key, (handle, count) in self.handles.items():
            buffer = (ctypes.c_ulonglong * count)()
            self._check(self.lib.MPI_T_pvar_read(self.session, handle, buffer), key)
            values[key] = np.array(buffer, dtype=np.float64)
        return values

    def count(self, action) -> dict[str, np.ndarray]:
        """What this rank sent while ``action()`` ran."""
        before = self.read()
        action()
        after = self.read()
        return {key: after[key] - before[key] for key in before}


def sent(counts: dict[str, np.ndarray]) -> dict[str, float]:
    """A record of `Monitor.count`: messages and bytes to ranks 1, 2, … (a working rank's neighbours; every
    working rank for rank 0) and to rank 0, the peers, and the collective operations."""
    messages, size = counts["messages"], counts["bytes"]
    return {"messages": float(messages[1:].sum()), "messages_to_rank0": float(messages[0]),
            "bytes": float(size[1:].sum()), "bytes_to_rank0": float(size[0]), "peers": int(np.count_nonzero(messages)),
            "collectives": float(counts["all_to_all"][0] + counts["one_to_all"][0] + counts["all_to_one"][0])}


def solver_record(spaces, case, comm) -> dict:
    """The distributed solver's pieces built (no time step): the messages this rank sends in one step-matrix
    product, preconditioner application, inner product and MinRes iteration (NGSolve's MinResSolver without a
    tolerance), and the relative residual of BDDC as a solver of its form A ⊕ Δt²/ρ_F L_p (one random vector)."""
    import ngsolve as ngs
    from ngsolve.krylovspace import MinResSolver

    from fsivsp import forms
    from fsivsp.solvers.distributed import distributed_solver

    tau = case.time_scheme.tau(case.dt)
    matrix = forms.step_matrix(spaces, case.materials, tau).Assemble().mat
    preconditioner = distributed_solver(matrix, spaces, case.materials, tau, "auto").preconditioner
    pre = preconditioner.mat
    x, y = matrix.CreateColVector(), matrix.CreateColVector()
    x.FV().NumPy()[:] = 1.0
    monitor = Monitor(comm)

    def applied(operator):  # to an input as a product leaves it (distributed: not yet summed over ranks)
        def run():
            x.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
            y.data = operator * x
        return run

    def minres(iterations: int):
        solver = MinResSolver(matrix, pre, tol=None, atol=1e-300, maxiter=iterations)

        def run():
            x.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
            solver.Solve(x, y)
        return run

    record = {"matrix_product": monitor.count(applied(matrix)), "preconditioner": monitor.count(applied(pre)),
              "inner_product": monitor.count(lambda: ngs.InnerProduct(x, y))}
    few, many = (monitor.count(minres(k)) for k in ITERATIONS)
    record["minres_iteration"] = {key: (many[key] - few[key]) / (ITERATIONS[1] - ITERATIONS[0]) for key in few}
    product, blocks, bddc, _ = preconditioner._keep
    free = ngs.Projector(product.FreeDofs(), True)
    b, r = blocks.mat.CreateColVector(), blocks.mat.CreateColVector()
    b.SetRandom()
    b.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
    b.data = free * b
    r.data = free * (b - blocks.mat * (bddc.mat * b))
    return {"messages": {name: sent(counts) for name, counts in record.items()},
            "bddc_residual": ngs.Norm(r) / ngs.Norm(b)}


def child(case_path: Path, out: Path, messages_up_to: int) -> None:
    """Under mpirun: every rank's partition record (and messages), gathered into ``out`` by rank 0."""
    import ngsolve as ngs

    from fsivsp import parallel
    from fsivsp.runcase import boundary_conditions, load_run_case
    from fsivsp.spaces import build_spaces, global_count

    case = parallel.shared_case(load_run_case, case_path)
    mesh = case.mesh
    velocity, _ = boundary_conditions(case)
    spaces = build_spaces(mesh, case.discretisation.family, case.discretisation.order, "|".join(velocity))
    X = spaces.mixed
    dofs = X.ParallelDofs()
    neighbours = list(dofs.ExchangeProcs())
    shared = np.zeros(X.ndof, dtype=bool)
    for rank in neighbours:
        shared[list(dofs.Proc2Dof(rank))] = True
    free = np.fromiter(X.FreeDofs(), dtype=bool, count=X.ndof)
    wirebasket = np.array([X.CouplingType(d) == ngs.COUPLING_TYPE.WIREBASKET_DOF for d in range(X.ndof)], dtype=bool)
    record = {"rank": mesh.comm.rank, "cells": mesh.ne, "dofs": X.ndof, "free": int(free.sum()),
              "shared": int(shared.sum()), "interface": int((shared & free).sum()), "neighbours": len(neighbours),
              "wirebasket": int((wirebasket & free).sum()),
              "interface_wirebasket": int((wirebasket & shared & free).sum())}
    unknowns = spaces.free_dofs()
    totals = {"unknowns": unknowns,
              "wirebasket": global_count(X, ngs.BitArray(list(wirebasket & free))),
              "interface": global_count(X, ngs.BitArray(list(shared & free)))}
    if unknowns <= messages_up_to:
        record.update(solver_record(spaces, case, mesh.comm.mpi4py))
    records = parallel.gather_on_root(record)
    if parallel.is_root():
        out.write_text(json.dumps({"ranks": len(records), **totals, "per_rank": records}))


def measure(case: Path, ranks: int, messages_up_to: int, out: Path) -> dict:
    """One ``mpirun -np ranks`` of `child` and its record."""
    mpirun = shutil.which("mpirun", path=str(Path(sys.executable).parent)) or "mpirun"
    command = [mpirun, "-np", str(ranks), sys.executable, __file__, "--child", str(case), "--out", str(out),
               "--messages-up-to", str(messages_up_to)]
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PRTE_MCA_rmaps_default_mapping_policy=":oversubscribe",
               OMPI_MCA_pml_monitoring_enable="2")
    subprocess.run(command, check=True, env=env)
    return json.loads(out.read_text())


# -- on paper -----------------------------------------------------------------------------------------------------


def loglinear(n: float, table) -> float:
    """Iterations at n unknowns, piecewise linear in (log n, log its) through ``table``, the end segments
    extended beyond it."""
    logs = np.log(np.array(table, dtype=float))
    k = int(np.clip(np.searchsorted(logs[:, 0], math.log(n)) - 1, 0, len(logs) - 2))
    (x0, y0), (x1, y1) = logs[k], logs[k + 1]
    return math.exp(y0 + (y1 - y0) * (math.log(n) - x0) / (x1 - x0))


def lattice(parts: int) -> float:
    """Interface area per part of a cube cut into ``parts`` equal cubes, in units of the cube's face:
    6 (P^(1/3) − 1)/P, which tends to 6 P^(−2/3), the surface-to-volume law."""
    return 6 * (parts ** (1 / 3) - 1) / parts


def fit(runs: list[dict]) -> dict:
    """α of the interface law: interface unknowns per part = α N^(2/3) · 6 (P^(1/3) − 1)/P (geometric mean over
    the runs with P ≥ 2 parts) and its spread; the ratios the extrapolation carries over, from the finest mesh
    (with the most parts) and the finest mesh whose messages were counted; the neighbour exchanges per MinRes
    iteration (messages to neighbours per neighbour, the largest over the counted runs)."""
    cut = [r for r in runs if r["parts"] >= 2]
    alphas = [r["interface_mean"] / (r["unknowns"] ** (2 / 3) * lattice(r["parts"])) for r in cut]
    finest = max(cut, key=lambda r: (r["unknowns"], r["parts"]))
    counted = [r for r in runs if "messages" in r]
    finest_counted = max(counted, key=lambda r: (r["unknowns"], r["parts"]))
    return {"alpha": float(np.exp(np.mean(np.log(alphas)))), "alpha_min": min(alphas), "alpha_max": max(alphas),
            "wirebasket_fraction": finest["wirebasket"] / finest["unknowns"],
            "multiplicity": finest["interface_sum"] / finest["interface"],
            "shared_per_interface": finest["shared_sum"] / finest["interface_sum"],
            "dofs_per_unknown": finest["dofs_sum"] / finest["unknowns"],
            "coarse_bytes_per_unknown": (finest_counted["messages"]["minres_iteration"]["rank0"]["bytes"]
                                         / finest_counted["unknowns"]),
            "neighbour_exchanges": max(r["messages"]["minres_iteration"]["workers_max"]["messages"]
                                       / r["neighbours_max"] for r in counted if r["neighbours_max"])}


def extrapolate(unknowns: float, ranks: int, law: dict) -> dict:
    """The figures of ``ranks`` ranks (P = ranks − 1 parts) on ``unknowns`` free unknowns from the `fit`."""
    parts = ranks - 1
    interface = law["alpha"] * unknowns ** (2 / 3) * lattice(parts)
    its = {"serial": loglinear(unknowns, SERIAL_ITERATIONS), "bddc": loglinear(unknowns, BDDC_ITERATIONS)}
    per_iteration = law["neighbour_exchanges"] * NEIGHBOURS_MANY_PARTS + 1  # and one coarse gather to rank 0
    growth = (unknowns / COARSE_REFERENCE["unknowns"]) ** FILL_EXPONENT
    # the exponent between the 2-rank runs of 197 682 (finished) and 587 262 unknowns (stopped, so a lower bound)
    observed = math.log(COARSE_STOPPED["gib"] / COARSE_REFERENCE["gib"],
                        COARSE_STOPPED["unknowns"] / COARSE_REFERENCE["unknowns"])
    return {"ranks": ranks, "parts": parts, "unknowns": unknowns, "unknowns_per_part": unknowns / parts,
            "interface_per_part": interface,
            "interface_range": [interface * law[k] / law["alpha"] for k in ("alpha_min", "alpha_max")],
            "interface_fraction": interface / (unknowns / parts), "neighbours": NEIGHBOURS_MANY_PARTS,
            "messages_per_iteration": per_iteration,
            "bytes_per_iteration": law["neighbour_exchanges"] * 8 * interface * law["shared_per_interface"],
            "rank0_messages_per_iteration": 2 * parts,
            "rank0_bytes_per_iteration": 2 * law["coarse_bytes_per_unknown"] * unknowns,
            "allreduces_per_iteration": 2, "iterations": its,
            "messages_per_step": {k: v * per_iteration for k, v in its.items()},
            "rank0_messages_per_step": {k: v * 2 * parts for k, v in its.items()},
            "allreduces_per_step": {k: 2 * v for k, v in its.items()},
            "wirebasket": law["wirebasket_fraction"] * unknowns,
            "interface_unknowns": parts * interface / law["multiplicity"],
            "coarse_gib": COARSE_REFERENCE["gib"] * growth, "coarse_exponent_observed": observed,
            "coarse_gib_observed": COARSE_REFERENCE["gib"] * (unknowns / COARSE_REFERENCE["unknowns"]) ** observed,
            "coarse_seconds_per_iteration": COARSE_REFERENCE["seconds_per_iteration"] * growth,
            "coarse_seconds_per_step": COARSE_REFERENCE["seconds_per_iteration"] * growth * its["bddc"],
            "checkpoint_bytes": 16 * law["dofs_per_unknown"] * unknowns}


def run_record(raw: dict, refine: int) -> dict:
    """A child's record with the means and sums over the working ranks (rank 0 holds no cells)."""
    workers = [r for r in raw["per_rank"] if r["cells"]]
    record = {"refine": refine, "ranks": raw["ranks"], "parts": len(workers), "unknowns": raw["unknowns"],
              "wirebasket": raw["wirebasket"], "interface": raw["interface"], "per_rank": raw["per_rank"]}
    for key in ("cells", "free", "interface", "neighbours", "shared", "dofs"):
        values = [r[key] for r in workers]
        record.update({f"{key}_mean": float(np.mean(values)), f"{key}_max": max(values), f"{key}_sum": sum(values)})
    if "messages" in raw["per_rank"][0]:
        record["bddc_residual"] = raw["per_rank"][0]["bddc_residual"]
        record["messages"] = {op: {"workers_max": {k: max(r["messages"][op][k] for r in workers)
                                                   for k in workers[0]["messages"][op]},
                                   "rank0": raw["per_rank"][0]["messages"][op]}
                              for op in raw["per_rank"][0]["messages"]}
    return record


def print_measured(runs: list[dict]) -> None:
    print("measured (set-up only; P = ranks − 1 parts; per part: mean (max); messages and bytes sent by the busiest"
          " part: to neighbours, to rank 0; by rank 0; BDDC: relative residual as a solver of A ⊕ L_p)")
    print("refine  unknowns  ranks  cells/part  unknowns/part     interface/part  neighb.  wirebasket  "
          "MinRes it.: messages  bytes                   collectives  product  precond.  inner  BDDC")
    for r in runs:
        line = (f"{r['refine']:6d}  {r['unknowns']:8d}  {r['ranks']:5d}  {r['cells_mean']:10.0f}  "
                f"{r['free_mean']:8.0f} ({r['free_max']:6d})  {r['interface_mean']:6.0f} ({r['interface_max']:5d})"
                f"  {r['neighbours_max']:7d}  {r['wirebasket']:10d}")
        if "messages" in r:
            m = {op: (record["workers_max"], record["rank0"]) for op, record in r["messages"].items()}
            part, root = m["minres_iteration"]
            line += (f"  {part['messages']:7.0f}, {part['messages_to_rank0']:.0f}, {root['messages']:.0f}"
                     f"   {part['bytes']:6.0f}, {part['bytes_to_rank0']:6.0f}, {root['bytes']:6.0f}"
                     f"  {part['collectives']:11.0f}  {m['matrix_product'][0]['messages']:7.0f}"
                     f"  {m['preconditioner'][0]['messages']:6.0f}+{m['preconditioner'][0]['messages_to_rank0']:.0f}"
                     f"  {m['inner_product'][0]['collectives']:5.0f}  {r['bddc_residual']:.0e}")
        print(line)


def print_extrapolated(law: dict, scenarios: list[tuple[str, dict]]) -> None:
    print(f"\nextrapolated: interface/part = α N^(2/3) 6 (P^(1/3) − 1)/P, α = {law['alpha']:.3f} "
          f"({law['alpha_min']:.3f}–{law['alpha_max']:.3f}); {law['neighbour_exchanges']:.0f} neighbour exchanges "
          f"per MinRes iteration (measured), {NEIGHBOURS_MANY_PARTS} neighbours (assumed); wirebasket "
          f"{law['wirebasket_fraction']:.3f} N; coarse factor and solve ∝ N^{FILL_EXPONENT:.2f} from "
          f"{COARSE_REFERENCE['gib']} GiB, {COARSE_REFERENCE['seconds_per_iteration']:.2f} s per iteration at "
          f"{COARSE_REFERENCE['unknowns']}")
    rows = [("unknowns per part", lambda e: f"{e['unknowns_per_part']:.0f}"),
            ("interface unknowns per part", lambda e: "{:.0f} ({:.0f}–{:.0f})".format(e["interface_per_part"],
                                                                                      *e["interface_range"])),
            ("interface / unknowns of a part", lambda e: f"{e['interface_fraction']:.2f}"),
            ("messages sent per iteration, part", lambda e: f"{e['messages_per_iteration']:.0f}"),
            ("bytes to neighbours per iteration, part", lambda e: f"{e['bytes_per_iteration']:.2e}"),
            ("messages per iteration, rank 0 (in+out)", lambda e: f"{e['rank0_messages_per_iteration']}"),
            ("bytes per iteration, rank 0 (in+out)", lambda e: f"{e['rank0_bytes_per_iteration']:.2e}"),
            ("MinRes its (serial law, BDDC law)", lambda e: "{serial:.0f}, {bddc:.0f}".format(**e["iterations"])),
            ("messages per step, part (BDDC its)", lambda e: f"{e['messages_per_step']['bddc']:.0f}"),
            ("messages per step, rank 0 (BDDC its)", lambda e: f"{e['rank0_messages_per_step']['bddc']:.3g}"),
            ("allreduces per step (BDDC its)", lambda e: f"{e['allreduces_per_step']['bddc']:.0f}"),
            ("NGSolve wirebasket (coarse) dofs", lambda e: f"{e['wirebasket']:.3g}"),
            ("coarse factor GiB, N^4/3 (observed law)",
             lambda e: f"{e['coarse_gib']:.3g} ({e['coarse_gib_observed']:.3g})"),
            ("coarse solve s per iteration", lambda e: f"{e['coarse_seconds_per_iteration']:.3g}"),
            ("coarse solve s per step (BDDC its)", lambda e: f"{e['coarse_seconds_per_step']:.3g}"),
            ("interface unknowns, all ranks", lambda e: f"{e['interface_unknowns']:.3g}"),
            ("checkpoint bytes gathered on rank 0", lambda e: f"{e['checkpoint_bytes']:.2e}")]
    print(f"{'':40s}" + "".join(f"{name:>20s}" for name, _ in scenarios))
    for label, cell in rows:
        print(f"{label:40s}" + "".join(f"{cell(e):>20s}" for _, e in scenarios))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--case", type=Path, default=ROOT / "examples" / "large_ball_3d.toml")
    parser.add_argument("--refine", default="1,2,3", help="comma-separated refinements of the case's mesh")
    parser.add_argument("--ranks", default="2,3,4,5", help="comma-separated rank counts (mpirun -np)")
    parser.add_argument("--messages-up-to", type=int, default=50_000,
                        help="count messages (build the solver) up to this many unknowns")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--child", type=Path, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        return child(args.child, args.out, args.messages_up_to)
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from mpi_scaling import case_text

    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for refine in (int(r) for r in re.split(r"[, ]+", args.refine) if r):
            case = Path(tmp) / f"refine{refine}.toml"
            case.write_text(case_text(args.case, refine, 1))
            for ranks in (int(n) for n in re.split(r"[, ]+", args.ranks) if n):
                runs.append(run_record(measure(case, ranks, args.messages_up_to, Path(tmp) / "out.json"), refine))
    print(f"{args.case.name}, {os.cpu_count()} cores")
    print_measured(runs)
    law = fit(runs)
    scenarios = [(f"strong, {ranks} ranks", extrapolate(STRONG_UNKNOWNS, ranks, law)) for ranks in (64, 1024)]
    scenarios += [(f"weak, {ranks} ranks", extrapolate(WEAK_UNKNOWNS_PER_RANK * (ranks - 1), ranks, law))
                  for ranks in (64, 1024)]
    print_extrapolated(law, scenarios)
    if args.json:
        args.json.write_text(json.dumps({"case": args.case.name, "cores": os.cpu_count(), "runs": runs, "law": law,
                                         "assumed": {"neighbours": NEIGHBOURS_MANY_PARTS,
                                                     "fill_exponent": FILL_EXPONENT},
                                         "iterations": {"serial": SERIAL_ITERATIONS, "bddc": BDDC_ITERATIONS},
                                         "coarse_reference": COARSE_REFERENCE, "coarse_stopped": COARSE_STOPPED,
                                         "extrapolated": dict(scenarios)}, indent=1) + "\n")


if __name__ == "__main__":
    main()
