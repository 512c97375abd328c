"""MPI-distributed runs (docs/mpi.md): ``mpirun -np 2 fsivsp ...`` gives the serial run's numbers, and bad input
ends every rank with exit 2 and one line. A hung rank fails its test by pytest-timeout (pyproject's `timeout`), which
ends mpirun."""
import json
import os
import subprocess
import sys
from pathlib import Path

import meshio
import numpy as np
import pytest
from support.cases import TUBE, mpirun, needs_mpi

from fsivsp.app.cli import main
from fsivsp.runtime import parallel

ROOT = Path(__file__).resolve().parents[2]
RELATIVE = 1e-6
#: The step solves to 1e-12 of the right-hand side: ranks and the serial run then agree to round-off, not to the
#: auto tolerance's algebraic error (`solvers.START_REDUCTION`).
TIGHT = ("--set", "discretisation.tolerance=1e-12")

#: ``fsivsp ARGS`` with `geometry.distribute.FAIR_SHARE` set to ``SHARE`` (the first argument), so that the tests'
#: small meshes are refined partly on rank 0 and partly on every rank, as large ones are.
SHARED = """
import importlib, sys
from fsivsp.app.cli import main
importlib.import_module("fsivsp.geometry.distribute").FAIR_SHARE = int(sys.argv.pop(1))  # the module, not the function
sys.exit(main(sys.argv[1:]))
"""


#: The 3D solid ball in a fluid box of examples/solid_in_fluid_3d.toml (curved), loaded in both media.
BALL = (ROOT / "examples" / "solid_in_fluid_3d.toml").read_text().split("[discretisation]")[0] + """
[data]
force_fluid = ["sin(pi*y)*t", "0", "0"]
force_solid = ["0", "x", "0"]

[output]
vtk = false
"""

#: The 2D fluid disk in a solid square of examples/fluid_in_solid_2d.toml, Taylor–Hood on curved cells, refined once.
DISK = (ROOT / "examples" / "fluid_in_solid_2d.toml").read_text().split("[discretisation]")[0].replace(
    "[geometry]", "[geometry]\nrefine = 1") + """
[discretisation]
family = "taylor_hood"

[data]
force_fluid = ["sin(pi*y)*t", "0"]
force_solid = ["0", "x"]

[output]
vtk = false
"""


def assert_close(serial: dict, distributed: dict, where: str, relative: float = RELATIVE) -> None:
    for name, value in serial.items():
        assert distributed[name] == pytest.approx(value, rel=relative, abs=1e-300), f"{where}: {name}"


def test_serial_helpers_are_identities():
    """Without mpirun nothing imports MPI and the helpers do the serial thing."""
    assert parallel.world() is None and parallel.size() == 1 and parallel.is_root()
    assert parallel.shared(lambda a: a + 1, 1) == 2 and parallel.on_root(lambda: 3) == 3
    assert parallel.settle(5) == 5 and parallel.gather(7) == [7]


@needs_mpi
@pytest.mark.parametrize("text, family, solver, ranks, relative", [
    (BALL, None, "iterative", 2, RELATIVE), (TUBE, "mini", None, 2, RELATIVE),
    (BALL.replace("[geometry]", "[geometry]\nrefine = 2").replace("maxh = 0.4", "maxh = 0.6").replace("T = 0.1\n",
                                                                                                  "T = 0.04\n"),
     None, "petsc", 3, 1e-8),
    (TUBE, "mini", "direct", 2, RELATIVE), (DISK, None, None, 2, 1e-8),
    (BALL.replace("T = 0.1\n", "T = 0.04\n") + '[discretisation]\nfamily = "taylor_hood"\norder = 2\n', None,
     "petsc", 2, 1e-8),
    (BALL + '[discretisation]\nsolid_pressure = "continuous"\n[solver.petsc]\nvelocity_preconditioner = "condensed"\n',
     None, "petsc", 2, RELATIVE)],
    ids=["ball-3d-iterative", "tube-2d-auto-petsc", "ball-3d-refined-on-3-ranks", "tube-2d-mumps", "disk-2d-curved",
         "ball-3d-taylor-hood-2-p-multigrid", "ball-3d-solid-pressure-condensed"])
def test_run_equals_serial(tmp_path, text, family, solver, ranks, relative):
    """``fsivsp run`` on 2 (3) ranks: the same counts, energies at every step and final L² norms as the serial
    run; PETSc's solvers over all ranks (rank 0 too) by default and with ``"iterative"``, ``"petsc"`` or ``"direct"``
    (MUMPS). The ball refined twice on 3 ranks, the first time on rank 0 and the second on every rank (onto the
    sphere; a small `FAIR_SHARE`), gives the serial refinement's mesh, so the serial run's numbers to 1e-8, and so
    does the disk refined on the ranks, its Taylor–Hood cells curved there (until issue 36 only rank 0 had the
    geometry: the other ranks' cells stayed straight); the ranks' cells add up to the mesh's, rank 0 holding none."""
    case = tmp_path / "case.toml"
    text = text.format(family=family)
    if solver:
        text = (text.replace("[discretisation]", f'[discretisation]\nsolver = "{solver}"', 1)
                if "[discretisation]" in text else text + f'\n[discretisation]\nsolver = "{solver}"\n')
    case.write_text(text)
    script = tmp_path / "shared.py"
    script.write_text(SHARED)
    assert main(["run", str(case), "--out", str(tmp_path / "serial"), "--quiet", *TIGHT]) == 0
    done = mpirun(str(script), "100", "run", str(case), "--out", str(tmp_path / "mpi"), "--quiet", *TIGHT, ranks=ranks,
                  program=())
    assert done.returncode == 0, done.stderr
    serial, distributed = (json.loads((tmp_path / name / "summary.json").read_text()) for name in ("serial", "mpi"))
    assert distributed["solver"]["method"] == "petsc"
    ranked = distributed["ranks"]
    assert ranked["size"] == ranks and sum(ranked["cells"]) == serial["mesh"]["cells"] and ranked["cells"][0] == 0
    assert all(len(ranked[key]) == ranks for key in ("mesh_peak_memory_bytes", "unknowns", "setup_seconds"))
    assert all(0 < mesh <= peak for mesh, peak in zip(ranked["mesh_peak_memory_bytes"], ranked["peak_memory_bytes"]))
    assert (distributed["mesh"], distributed["dofs"]) == (serial["mesh"], serial["dofs"])
    assert_close(serial["l2_norms"], distributed["l2_norms"], "L² norm", relative)
    assert_close(dict(enumerate(serial["energy"]["energy"])), dict(enumerate(distributed["energy"]["energy"])),
                 "energy at step", relative)
    for table in ("probes.csv", "lines.csv") if "probes" in text else ():  # each point evaluated on one rank
        expected, got = (np.genfromtxt(tmp_path / name / table, delimiter=",", skip_header=1, ndmin=2)
                         for name in ("serial", "mpi"))
        scale = np.nanmax(np.where(np.isnan(expected), 0.0, np.abs(expected)), axis=0)  # per column
        close = np.isclose(got, expected, rtol=RELATIVE, atol=0.0, equal_nan=True) \
            | (np.abs(got - expected) <= RELATIVE * scale)  # NaN: the pressure at a point in the solid
        assert close.all(), f"{table}: rows, columns {np.argwhere(~close)[:5].tolist()}"
    if "every = 5" in text:  # one piece per rank with cells (rank 0 has none), all cells, the same largest values
        whole = meshio.read(tmp_path / "serial" / "vtk" / "fields_000005.vtu")
        pieces = [meshio.read(tmp_path / "mpi" / "vtk" / "fields_000005_proc1.vtu")]
        assert "fields_000005_proc1.vtu" in (tmp_path / "mpi" / "vtk" / "fields.pvd").read_text()
        assert sum(len(c.data) for p in pieces for c in p.cells) == sum(len(c.data) for c in whole.cells)
        for name, values in whole.point_data.items():
            assert max(abs(p.point_data[name]).max() for p in pieces) == pytest.approx(abs(values).max(), rel=RELATIVE)


#: Solves with an SPD and a singular (Neumann) Gram matrix by `solvers.symmetric` on the unit square (serial or
#: distributed), printed by rank 0 as kernel-free integrals of the solutions.
SYMMETRIC = """
import json
import numpy as np
import ngsolve as ngs
from netgen.geom2d import unit_square
from fsivsp.runtime import parallel
from fsivsp.geometry import distribute
from fsivsp.solvers.sparse import bits
from fsivsp.solvers.symmetric import symmetric_solver

mesh = distribute(parallel.on_root(lambda: ngs.Mesh(unit_square.GenerateMesh(maxh=0.1))))
space = ngs.H1(mesh, order=2)
u, w = space.TnT()
constants = np.zeros((space.ndof, 1))
constants[:mesh.nv] = 1.0  # the vertex dofs come first
results = {}
for name, mass in (("spd", 1.0), ("singular", 0.0)):
    gram = ngs.BilinearForm(space, symmetric=True)
    gram += (mass * u * w + ngs.grad(u) * ngs.grad(w)) * ngs.dx
    load = ngs.LinearForm((ngs.x - 0.5) * w * ngs.dx).Assemble()
    kernel = (constants / np.linalg.norm(constants), slice(None)) if mass == 0 else None
    solve = symmetric_solver(gram.Assemble().mat, bits(np.ones(space.ndof, dtype=bool)), kernel)
    gf = ngs.GridFunction(space)
    solve(load.vec, gf.vec)
    results[name] = [ngs.Integrate(ngs.grad(gf) * ngs.grad(gf), mesh), ngs.Integrate(gf.Deriv()[0], mesh)]
if parallel.is_root():
    print(json.dumps(results))
"""


@needs_mpi
def test_symmetric_solves_equal_serial(tmp_path):
    """`solvers.symmetric` (the error norms' Gram matrices) on 2 ranks, MUMPS
    (`solvers.mumps`): the solutions of the serial factorisation to 1e-12 (measured: 2.5e-15)."""
    script = tmp_path / "symmetric.py"
    script.write_text(SYMMETRIC)
    serial = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                            env=dict(os.environ, PYTHONPATH=str(ROOT / "src")))
    done = mpirun(str(script), program=())
    assert serial.returncode == 0 and done.returncode == 0, serial.stderr + done.stderr
    expected, got = json.loads(serial.stdout), json.loads(done.stdout)
    for name, values in expected.items():
        assert got[name] == pytest.approx(values, rel=1e-12), name


@needs_mpi
def test_initial_projection_equals_serial(tmp_path):
    """v⁰_h by the projections (22)–(23), factorised by MUMPS over 2 ranks (`solvers.mumps`): the energies at every
    step (step 0 is the projection's) and the final L² norms as serially, to 1e-10 (measured: 9e-12, the step
    solver's tolerance)."""
    case = tmp_path / "case.toml"
    projected = 'family = "mini"\ninitial_velocity = "projection"'
    case.write_text(TUBE.format(family="mini").replace('family = "mini"', projected)
                    + '\n[data]\nvelocity0 = ["x*(2 - x)", "0.1*x"]\n')
    assert main(["run", str(case), "--out", str(tmp_path / "serial"), "--quiet", *TIGHT]) == 0
    done = mpirun("run", str(case), "--out", str(tmp_path / "mpi"), "--quiet", *TIGHT)
    assert done.returncode == 0, done.stderr
    serial, distributed = (json.loads((tmp_path / name / "summary.json").read_text()) for name in ("serial", "mpi"))
    assert serial["energy"]["energy"][0] > 0
    assert distributed["energy"]["energy"] == pytest.approx(serial["energy"]["energy"], rel=1e-10)
    for name, value in serial["l2_norms"].items():
        assert distributed["l2_norms"][name] == pytest.approx(value, rel=1e-10), name


@needs_mpi
@pytest.mark.parametrize("command", [["paper", "--dt", "0.1", "--levels", "0-2", "--tolerance", "1e-12"],
                                     ["study", str(ROOT / "examples" / "fluid_over_solid_2d.toml"), "--levels", "0-1"],
                                     ["study", str(ROOT / "examples" / "time_convergence_2d.toml"), "--level", "1",
                                      "--dt", "0.1,0.05"]],
                         ids=["paper", "study-2d", "time-study-2d"])
def test_errors_equal_serial(tmp_path, command):
    """The paper's experiment (levels 0–2), a 2D Taylor–Hood study and a study in time (its Δt on one mesh: until
    issue 36 the second Δt crashed rank 0, on the mesh ``Distribute`` had emptied) on 2 ranks: every error norm as
    in the serial run (the study's case file at tolerance 1e-12)."""
    if command[0] == "study":
        case = tmp_path / "case.toml"
        case.write_text(Path(command[1]).read_text().replace("[discretisation]", "[discretisation]\ntolerance = 1e-12"))
        command = [command[0], str(case), *command[2:]]
    assert main([*command, "--json", str(tmp_path / "serial.json"), "--quiet"]) == 0
    done = mpirun(*command, "--json", str(tmp_path / "mpi.json"), "--quiet")
    assert done.returncode == 0, done.stderr
    serial, distributed = (json.loads((tmp_path / name).read_text()) for name in ("serial.json", "mpi.json"))
    assert [r["level"] for r in distributed] == [r["level"] for r in serial]
    for s, d in zip(serial, distributed):
        assert d["solver"] == "petsc" and (d["vertices"], d["dofs"]) == (s["vertices"], s["dofs"])
        assert_close(s["errors"], d["errors"], f"level {s['level']}")


@needs_mpi
@pytest.mark.parametrize("old, new, args, message", [
    ("[boundary.solid_ends]", "[boundary.nowhere]", [],  # found while meshing, on rank 0 only
     "error: boundary.nowhere: no boundary of that name"),
    ('family = "mini"', 'family = "mini"\nsolver = "umfpack"', [],
     "error: discretisation.solver: 'umfpack' does not run under mpirun"),
    ("probes = [[0.5, 0.0], [1.0, 0.0], [1.0, 0.55]]", "probes = [[0.5, 0.0], [10.0, 0.0]]", [],
     "error: probe 1 at (10, 0) is outside the mesh; expected a point in its bounding box"),
    ('[boundary.solid_wall]\ntraction = ["0", "0"]', '[boundary.solid_wall]\nflow = "1"', [],
     "error: boundary.solid_wall.flow: expected a boundary of the fluid, got one of the solid"),
], ids=["boundary", "serial-direct-solver", "probe-outside", "flow-on-the-wall"])
def test_bad_input_ends_every_rank(tmp_path, old, new, args, message):
    """Exit 2 (mpirun's code: every rank's), the error printed once, no rank left running (a rank left would hang
    mpirun: pytest-timeout fails it)."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini").replace(old, new))
    done = mpirun("run", str(case), "--out", str(tmp_path / "out"), *args)
    assert done.returncode == 2, done.stderr
    ours = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(ours) == 1 and ours[0].startswith(message), done.stderr
    assert "Traceback" not in done.stderr


@needs_mpi
def test_outlets_inflow_support_and_surfaces_equal_serial(tmp_path):
    """The vessel of test_boundaries.py (a Womersley inflow, an RCR outlet, tissue support, surfaces) on 2 ranks with
    PETSc over both: the energies, the outlet's P and Q, and every column of surfaces.csv as serially to 1e-8 of the
    column's largest value (measured ≤ 2.3e-9, the y-force on Γ, which cancels between the walls; the inflow's flux
    to 3e-16)."""
    from test_boundaries import VESSEL

    case = tmp_path / "vessel.toml"
    case.write_text(VESSEL.format(T=0.1, every=100).replace("every = 5", "every = 10"))
    assert main(["run", str(case), "--out", str(tmp_path / "serial"), "--quiet", *TIGHT]) == 0
    done = mpirun("run", str(case), "--out", str(tmp_path / "mpi"), "--quiet", *TIGHT)
    assert done.returncode == 0, done.stderr
    serial, distributed = (json.loads((tmp_path / name / "summary.json").read_text()) for name in ("serial", "mpi"))
    assert distributed["solver"]["method"] == "petsc" and distributed["ranks"]["size"] == 2
    assert distributed["energy"]["energy"] == pytest.approx(serial["energy"]["energy"], rel=1e-8)
    for key, value in serial["outlets"]["outflow"].items():
        assert distributed["outlets"]["outflow"][key] == pytest.approx(value, rel=1e-8), key
    expected, got = (np.genfromtxt(tmp_path / name / "surfaces.csv", delimiter=",", skip_header=1)
                     for name in ("serial", "mpi"))
    scale = np.fmax.reduce(np.abs(expected), axis=0)   # NaN-ignoring; a solid boundary's pressure is NaN throughout
    close = np.isclose(got, expected, rtol=0.0, atol=0.0, equal_nan=True) | (np.abs(got - expected) <= 1e-8 * scale)
    assert close.all(), np.argwhere(~close)[:5].tolist()
    assert (tmp_path / "mpi" / "vtk" / "interface_000010_proc1.vtu").is_file()


@needs_mpi
def test_petsc_not_converging_ends_every_rank(tmp_path):
    """PETSc over 2 ranks stopped after 2 iterations: exit 3 on every rank, one line naming the solver."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini").replace('family = "mini"',
                                                       'family = "mini"\nsolver = "petsc"\nmax_iterations = 2'))
    done = mpirun("run", str(case), "--out", str(tmp_path / "out"))
    assert done.returncode == 3, done.stderr
    ours = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(ours) == 1 and "petsc: fgmres did not reach the tolerance" in ours[0], done.stderr
    assert "Traceback" not in done.stderr


def test_probe_outside_the_mesh_serial(tmp_path, capsys):
    """The same probe serially: one line naming it and the mesh's bounding box, exit 2."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini").replace("probes = [[0.5, 0.0], [1.0, 0.0], [1.0, 0.55]]",
                                                       "probes = [[0.5, 0.0], [10.0, 0.0]]"))
    assert main(["run", str(case), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: probe 1 at (10, 0) is outside the mesh; expected a point in "
                                               "its bounding box ["), err


#: ``fsivsp ARGS`` in which every rank sends itself ``signal`` during step ``step`` (as a scheduler signals the
#: ranks at its time limit), so that the test does not race the run.
SIGNALLED = """
import os, signal, sys
from fsivsp.timestepping.scheme import Scheme
from fsivsp.app.cli import main
original = Scheme.step
def step(self, *args, **kwargs):
    if self.n + 1 == {step}:
        os.kill(os.getpid(), signal.{signal})
    return original(self, *args, **kwargs)
Scheme.step = step
sys.exit(main(sys.argv[1:]))
"""


@needs_mpi
def test_killed_on_three_ranks_then_resumed_bit_for_bit(tmp_path):
    """3 ranks killed (SIGKILL) during step 4, after the checkpoint of step 2: every rank wrote its own part beside
    rank 0's manifest; resuming on 2 ranks is refused in one line; --resume on 3 ranks ends bit for bit as the
    uninterrupted run."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini") + "\n[checkpoint]\nevery = 2\n")
    script = tmp_path / "signalled.py"
    script.write_text(SIGNALLED.format(step=4, signal="SIGKILL"))
    cut = tmp_path / "cut"
    done = mpirun(str(script), "run", str(case), "--out", str(cut), "--quiet", ranks=3, program=())
    assert done.returncode != 0, done.stderr
    checkpoints = cut / "checkpoints"
    assert sorted(p.name for p in checkpoints.iterdir()) == ["checkpoint_000002.npz", "checkpoint_000002.parts"]
    assert sorted(p.name for p in (checkpoints / "checkpoint_000002.parts").iterdir()) == [
        f"rank{r:05d}.npz" for r in range(3)]
    done = mpirun("run", str(case), "--out", str(cut), "--resume", "--quiet")
    assert done.returncode == 2, done.stderr
    ours = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(ours) == 1 and "written by 3 ranks, this run has 2; resume with mpirun -np 3" in ours[0], done.stderr
    for args in (("--out", str(tmp_path / "whole")), ("--out", str(cut), "--resume")):
        done = mpirun("run", str(case), *args, "--quiet", ranks=3)
        assert done.returncode == 0, done.stderr
    whole, resumed = (json.loads((tmp_path / name / "summary.json").read_text()) for name in ("whole", "cut"))
    assert resumed["resumed_from"] == 2 and resumed["step"] == whole["step"] == 5
    assert resumed["l2_norms"] == whole["l2_norms"] and resumed["energy"] == whole["energy"]


@needs_mpi
def test_sigterm_on_two_ranks_then_resume(tmp_path):
    """SIGTERM on both ranks during step 3: they finish the step together, one line, a checkpoint at step 3, a
    summary with "terminated", exit 143; --resume under mpirun ends bit for bit as the uninterrupted run (PETSc, the
    default under mpirun, rounds alike from run to run on the same ranks)."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini"))
    script = tmp_path / "signalled.py"
    script.write_text(SIGNALLED.format(step=3, signal="SIGTERM"))
    cut = tmp_path / "cut"
    done = mpirun(str(script), "run", str(case), "--out", str(cut), "--quiet", program=())
    assert done.returncode == 143, done.stderr
    ours = [line for line in done.stderr.splitlines() if line.startswith("terminated")]
    checkpoint = cut / "checkpoints" / "checkpoint_000003.npz"
    assert ours == [f"terminated at step 3 (t = 0.00015): checkpoint {checkpoint}; continue with --resume"], done.stderr
    assert json.loads((cut / "summary.json").read_text())["status"] == "terminated"
    for args in (("--out", str(tmp_path / "whole")), ("--out", str(cut), "--resume")):
        done = mpirun("run", str(case), *args, "--quiet")
        assert done.returncode == 0, done.stderr
    whole, resumed = (json.loads((tmp_path / name / "summary.json").read_text()) for name in ("whole", "cut"))
    assert resumed["resumed_from"] == 3 and resumed["step"] == whole["step"] == 5
    assert resumed["l2_norms"] == whole["l2_norms"] and resumed["energy"] == whole["energy"]


@needs_mpi
def test_full_disk_on_two_ranks(tmp_path, tiny_disk):
    """A forced run into a 700 kB filesystem on 2 ranks: one line naming the file, exit 4, and every VTK piece the
    series lists reads with meshio."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini").replace("T = 2.5e-4", "T = 2e-3").replace("every = 5\nprobes",
                                                                                      "every = 1\nprobes"))
    out = tiny_disk / "out"
    done = mpirun("run", str(case), "--out", str(out), "--force", "--quiet")
    assert done.returncode == 4, done.stderr
    ours = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(ours) == 1 and ours[0].startswith("error: cannot write ") and "No space left" in ours[0], done.stderr
    series = out / "vtk" / "fields.pvd"
    if series.exists():
        import xml.etree.ElementTree as ET
        for item in ET.parse(series).getroot().iter("DataSet"):
            meshio.read(series.parent / item.get("file"))


@needs_mpi
def test_second_order_mesh_file_is_refused(tmp_path):
    """A gmsh file of curved triangle6 cells: one line naming the file, exit 2 on every rank."""
    from support.meshes import ball, curved_ball, mid_edge_nodes, second_order, write

    from fsivsp.geometry.export import to_meshio

    mesh_file = write(second_order(to_meshio(ball(2)), mid_edge_nodes(curved_ball(2))), tmp_path / "disk.msh")
    case = tmp_path / "case.toml"
    case.write_text((ROOT / "examples" / "fluid_in_solid_2d.toml").read_text().replace(
        'kind = "fluid_in_solid"\ndim = 2\nmaxh = 0.15', f'kind = "mesh"\ndim = 2\npath = "{mesh_file}"'))
    done = mpirun("study", str(case), "--levels", "0", "--quiet")
    assert done.returncode == 2, done.stderr
    ours = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert ours == [f"error: mesh file {mesh_file}: second-order cells are not supported under mpirun "
                    "(run serially, or write the file with first-order cells)"], done.stderr


@needs_mpi
def test_dry_run_counts_before_refining(tmp_path, capsys):
    """``--dry-run --set geometry.refine=4`` on 2 ranks: the serial dry run's unknowns and cells (counted from the
    mesh before refinement: no rank refines), the ranks and their node."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini"))
    args = ("run", str(case), "--out", str(tmp_path / "out"), "--set", "geometry.refine=4", "--dry-run")
    assert main(list(args)) == 0
    serial = capsys.readouterr().out.splitlines()
    done = mpirun(*args)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].split(" (")[0] == serial[0].split(" (")[0] and lines[1] == serial[1] == "cells: 140 288"  # 548·4⁴
    assert lines[-1].startswith("ranks: 2 on 1 node; the fullest, node 1: "), lines
    assert not (tmp_path / "out").exists()


@needs_mpi
def test_estimate_and_free_space_refusal_are_one_message(tmp_path, tiny_disk):
    """On 2 ranks: the estimate line once, then less free space than the output: one error line, exit 2, nothing
    written."""
    case = tmp_path / "case.toml"
    case.write_text(TUBE.format(family="mini").replace("T = 2.5e-4", "T = 2e-3").replace("every = 5\nprobes",
                                                                                      "every = 1\nprobes"))
    done = mpirun("run", str(case), "--out", str(tiny_disk / "out"))
    assert done.returncode == 2, done.stderr
    ours = [line for line in done.stderr.splitlines() if line.startswith(("estimate:", "error:"))]
    assert len(ours) == 2 and ours[0].startswith("estimate: 1 799 unknowns (petsc)"), done.stderr
    assert ours[1].startswith(f"error: fsivsp run: --out {tiny_disk / 'out'}: 0.7 MB free"), done.stderr
    assert not list(tiny_disk.iterdir())


@needs_mpi
def test_modes_equal_serial(tmp_path):
    """`fsivsp modes` on 2 ranks (SLEPc with complex scalars, MUMPS over the ranks; the mesh refined once where the
    cells live): the same unknowns and the same eigenvalues as serially to 1e-8 (measured 3.6e-14), their modes' VTU
    pieces as large; `fsivsp harmonic` (serial only) refused in one line."""
    from support.frequency import LID
    from support.frequency import fsivsp as command

    case = tmp_path / "box.toml"
    text = LID.split("[data]")[0].replace("maxh = 0.1\n", "maxh = 0.2\nrefine = 1\n")   # refined over the ranks
    case.write_text(text + "\n[modes]\ncount = 4\nnear = 1.5\n\n[output]\nvtk = true\n")
    serial = command("modes", case, "--out", tmp_path / "serial", "--quiet")
    done = mpirun("modes", str(case), "--out", str(tmp_path / "mpi"), "--quiet")
    assert serial.returncode == 0 and done.returncode == 0, serial.stderr + done.stderr
    expected, found = (json.loads((tmp_path / name / "summary.json").read_text()) for name in ("serial", "mpi"))
    assert found["ranks"]["size"] == 2 and found["dofs"] == expected["dofs"]
    assert found["eigensolver"]["unknowns"] == expected["eigensolver"]["unknowns"]
    assert len(found["modes"]) == len(expected["modes"]) == 4
    for a, b in zip(expected["modes"], found["modes"]):
        assert abs(complex(*a["s"]) - complex(*b["s"])) < 1e-8 * abs(complex(*a["s"]))
    whole = meshio.read(tmp_path / "serial" / "vtk" / "modes_000002.vtu")
    piece = meshio.read(tmp_path / "mpi" / "vtk" / "modes_000002_proc1.vtu")
    for name in ("velocity_real", "velocity_imag", "pressure_real", "stress_imag"):
        assert abs(piece.point_data[name]).max() == pytest.approx(abs(whole.point_data[name]).max(), rel=1e-8), name
    harmonic = mpirun("harmonic", str(case))
    ours = [line for line in harmonic.stderr.splitlines() if line.startswith("error:")]
    assert harmonic.returncode == 2 and ours == ["error: fsivsp harmonic: the harmonic response does not run under "
                                                 "mpirun (docs/mpi.md); run without mpirun"], harmonic.stderr
