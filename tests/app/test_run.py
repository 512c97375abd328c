"""`fsivsp run`: outputs, checkpoints and resume, interruption, divergence, and bad input."""
import csv
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import meshio
import numpy as np
import pytest
from support.cases import CASE, cli, final_fields, write_case

from fsivsp.app.cli import main


def test_run_writes_series_probes_plots_and_summary(tmp_path):
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path)), "--out", str(out), "--quiet"]) == 0
    pvd = (out / "vtk" / "fields.pvd").read_text()
    files = sorted((out / "vtk").glob("fields_*.vtu"))
    assert len(files) == 5 and pvd.count("<DataSet") == 5 and 'timestep="0.002' in pvd
    mesh = meshio.read(files[-1])
    for name, width in {"velocity": 2, "pressure": 1, "stress": 6, "von_mises": 1, "displacement": 2,
                        "region": 1}.items():
        data = mesh.point_data[name]
        assert data.shape[0] == len(mesh.points) and (data.shape[1] if data.ndim == 2 else 1) == width
        assert np.all(np.isfinite(data))
    assert np.abs(mesh.point_data["pressure"]).max() > 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["step"] == 40
    assert set(summary["l2_norms"]) == {"velocity", "pressure", "stress"} and summary["l2_norms"]["pressure"] > 0
    assert len(summary["energy"]["time"]) == 41 and summary["dofs"]["free"] > 0
    rows = list(csv.DictReader((out / "probes.csv").open()))
    assert len(rows) == 41 and {"p0_p", "p1_v1"} <= set(rows[0])
    assert len(list(csv.DictReader((out / "lines.csv").open()))) == 41 * 11
    for png in ("energy.png", "probes.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"
    # the two newest checkpoints are kept
    assert (sorted(p.name for p in (out / "checkpoints").glob("*.npz"))
            == ["checkpoint_000030.npz", "checkpoint_000040.npz"])




def wait_for(path_glob, directory: Path, process: subprocess.Popen) -> None:
    """Until ``process`` has written a file ``directory/path_glob`` (a step it reports); fails if it ends first."""
    while not (directory.exists() and list(directory.glob(path_glob))):
        assert process.poll() is None, process.communicate()
        time.sleep(0.05)


#: `fsivsp run` that reports the start of step ``argv[1]`` on stdout and waits there (for the test's SIGKILL).
_STOPS_AT = """
import sys
from fsivsp.app.cli import main
from fsivsp.timestepping.scheme import Scheme
step, original = int(sys.argv.pop(1)), Scheme.step

def step_or_wait(self, *args, **kwargs):
    if self.n + 1 == step:
        print(f"at step {step}", flush=True)
        sys.stdin.readline()
    return original(self, *args, **kwargs)

Scheme.step = step_or_wait
sys.exit(main(sys.argv[1:]))
"""


def test_killed_run_resumes_to_identical_results(tmp_path):
    """SIGKILL at step 47, which the run reports (no handler runs, no checkpoint of its own): the resume starts
    from the newest periodic checkpoint, step 40, and ends as the uninterrupted run."""
    case = write_case(tmp_path, T=0.005, every=20)  # 100 steps, checkpoints at 20, 40, ...
    reference = tmp_path / "reference"
    assert main(["run", str(case), "--out", str(reference), "--quiet"]) == 0
    out = tmp_path / "killed"
    process = subprocess.Popen([sys.executable, "-c", _STOPS_AT, "47", "run", str(case), "--out", str(out), "--quiet"],
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout.readline() == "at step 47\n"
    process.send_signal(signal.SIGKILL)
    assert process.wait() == -signal.SIGKILL
    assert sorted(p.name for p in (out / "checkpoints").glob("*.npz")) == ["checkpoint_000020.npz",
                                                                          "checkpoint_000040.npz"]
    assert main(["run", str(case), "--out", str(out), "--resume", "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["resumed_from"] == 40 and summary["step"] == 100
    ours, theirs = final_fields(out), final_fields(reference)
    for name in theirs:
        assert np.array_equal(ours[name], theirs[name]), name
    assert (out / "probes.csv").read_text() == (reference / "probes.csv").read_text()
    assert (out / "vtk" / "fields.pvd").read_text() == (reference / "vtk" / "fields.pvd").read_text()


def test_ctrl_c_writes_a_checkpoint_and_stops_cleanly(tmp_path):
    case = write_case(tmp_path, T=0.2, every=1000)  # 4000 steps: interrupted long before the end
    out = tmp_path / "out"
    process = cli("run", case, "--out", out, "--quiet")
    wait_for("fields_000010.vtu", out / "vtk", process)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate()
    assert process.returncode == 130 and "Traceback" not in err and "--resume" in err
    assert list((out / "checkpoints").glob("checkpoint_*.npz"))
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"


def test_a_non_finite_solution_stops_with_the_step_number(tmp_path, capsys):
    text = CASE.format(T=0.002, every=10).replace("[boundary.inflow]",
                                                  '[data]\nforce_fluid = ["log(x - 100)", "0"]\n\n[boundary.inflow]')
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, text=text)), "--out", str(out), "--quiet"]) == 3
    err = capsys.readouterr().err
    assert "not finite at step 1" in err and "\n" not in err.strip()
    assert (out / "vtk" / "fields_000000.vtu").exists()
    assert json.loads((out / "summary.json").read_text())["status"] == "diverged"


BAD = [
    ("[geometry]", "[geometry]\ncolour = 1", "geometry.colour"),
    ('kind = "elastic_tube"', 'kind = "pipe"', "geometry.kind"),
    ("dim = 2", "dim = 5", "geometry.dim"),
    ("dim = 2", 'dim = "2"', "geometry.dim"),
    ("maxh = 0.1", "maxh = 0", "geometry.maxh"),
    ("maxh = 0.1", "maxh = 0.1\nrefine = -1", "geometry.refine"),
    ("maxh = 0.1", "maxh = 0.1\nrefine = 7", "geometry.refine"),
    ("maxh = 0.1", 'maxh = 0.1\nrefine = "1"', "geometry.refine"),
    ("length = 2.0", "length = -2.0", "geometry.length"),
    ("rho_fluid = 1.0", "rho_fluid = 0", "materials.rho_fluid"),
    ("rho_solid = 1.2", "rho_solid = -1.2", "materials.rho_solid"),
    ("nu = 0.035", "nu = 0", "materials.nu"),
    ("nu = 0.035", 'nu = "water"', "materials.nu"),
    ("young = 3.0e6", "young = -3.0e6", "materials.young"),
    ("poisson = 0.3", "poisson = 0.5", "materials.poisson"),
    ("poisson = 0.3", "poisson = 0.3\nmu = 1.0", "materials.mu"),
    ("young = 3.0e6", "youngs = 3.0e6", "materials.youngs"),
    ("T = 0.002", "T = -1", "time.T"),
    ("dt = 5.0e-5", "dt = 0", "time.dt"),
    ("dt = 5.0e-5", "dt = 1.0", "time.dt"),
    ("[time]", "[time]\nsteps = 3", "time.steps"),
    ('family = "mini"', 'family = "p2p1"', "discretisation.family"),
    ('family = "mini"', 'family = "taylor_hood"\norder = 0', "discretisation.order"),
    ('family = "mini"', 'family = "mini"\nsolver = "magic"', "discretisation.solver"),
    ('family = "mini"', 'family = "mini"\ntolerance = 0', "discretisation.tolerance"),
    ('family = "mini"', 'family = "mini"\ntolerance = 1.0', "discretisation.tolerance"),
    ('family = "mini"', 'family = "mini"\nmax_iterations = 0', "discretisation.max_iterations"),
    ("[boundary.inflow]", "[boundary.inlet]", "boundary.inlet"),
    ("[boundary.solid_ends]", "[boundary.interface]", "boundary.interface"),
    ('traction = ["1.0e4*exp(-((t - 0.0005)/0.0002)**2)", "0"]', 'traction = ["1.0e4*exp(-((t - 0.0005)/0.0002)**2)"]',
     "boundary.inflow.traction"),
    ('traction = ["1.0e4*exp(-((t - 0.0005)/0.0002)**2)", "0"]', 'traction = ["pressure(t)", "0"]',
     "boundary.inflow.traction[0]"),
    ('traction = ["1.0e4*exp(-((t - 0.0005)/0.0002)**2)", "0"]', 'pressure = "1"', "boundary.inflow.pressure"),
    ('velocity = ["0", "0"]', 'velocity = ["0", "0"]\ntraction = ["0", "0"]', "boundary.solid_ends"),
    ('velocity = ["0", "0"]', 'velocity = ["os.system(1)", "0"]', "boundary.solid_ends.velocity[0]"),
    ('velocity = ["0", "0"]', 'velocity = ["__import__", "0"]', "boundary.solid_ends.velocity[0]"),
    ('velocity = ["0", "0"]', 'velocity = ["z", "0"]', "boundary.solid_ends.velocity[0]"),
    ("every = 10\n", "every = 0\n", "output.every"),
    ("every = 10\n", "every = 10\nformat = \"vtk\"\n", "output.format"),
    ("probes = [[0.5, 0.0], [1.0, 0.0]]", "probes = [[0.5, 0.0, 1.0]]", "output.probes[0]"),
    ("n = 11", "n = 0", "output.lines[0].n"),
    ("[checkpoint]\nevery = 10", "[checkpoint]\nevery = -5", "checkpoint.every"),
    ("[checkpoint]\nevery = 10", "[checkpoint]\nevery = 10\nkeep = 3", "checkpoint.keep"),
    ("[output]", "[outputs]", "outputs"),
    ("[materials]", "[materials]\nrho = 1", "materials.rho"),
    ('[discretisation]', '[data]\nvelocity0 = ["1", "2", "3"]\n\n[discretisation]', "data.velocity0"),
    ('[discretisation]', '[data]\nforce = ["1", "2"]\n\n[discretisation]', "data.force"),
    ('[discretisation]', '[data]\nforce_fluid = ["lambda: 1", "0"]\n\n[discretisation]', "data.force_fluid[0]"),
    ('[discretisation]', '[data]\ndisplacement0 = ["x.real", "0"]\n\n[discretisation]', "data.displacement0[0]"),
]


@pytest.mark.parametrize("old, new, field", BAD, ids=[b[2] + f"-{i}" for i, b in enumerate(BAD)])
def test_bad_input_exit_2_naming_the_field(tmp_path, capsys, old, new, field):
    text = CASE.format(T=0.002, every=10)
    assert old in text, old
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, text=text.replace(old, new, 1))), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and field in err and "Traceback" not in err, err
    assert not out.exists()


def test_not_toml(tmp_path, capsys):
    assert main(["run", str(write_case(tmp_path, text="[geometry\nkind = 1")), "--quiet"]) == 2
    assert "not valid TOML" in capsys.readouterr().err


@pytest.mark.parametrize("initial_stress", ["displacement", "projection"])
def test_initial_data_options_reach_the_run(tmp_path, initial_stress, discrete_divergence):
    """[discretisation] initial_stress and initial_velocity are honoured by `fsivsp run`: the projected σ⁰ has
    the mean of λ div(u⁰) I + 2μ ε(u⁰) over Ω_S (u⁰ quadratic), the interpolated displacement's does not;
    the projected v⁰ is discretely divergence-free."""
    import ngsolve as ngs

    from fsivsp.app.loop import build_scheme
    from fsivsp.config.production import load_run_case

    text = CASE.format(T=0.002, every=10).replace(
        '[discretisation]\nfamily = "mini"',
        f'[discretisation]\nfamily = "mini"\ninitial_stress = "{initial_stress}"\ninitial_velocity = "projection"\n\n'
        '[data]\nvelocity0 = ["x*(2 - x)*y", "0"]\ndisplacement0 = ["1.0e-4*x*x*y", "1.0e-4*y*y*x"]')
    scheme = build_scheme(load_run_case(write_case(tmp_path, text=text)))
    mesh, mat = scheme.spaces.mesh, scheme.materials
    x, y = ngs.x, ngs.y
    exact = 1.0e-4 * ngs.CF((mat.lam * 4 * x * y + 2 * mat.mu * 2 * x * y, 2 * mat.mu * (x * x + y * y) / 2,
                             2 * mat.mu * (x * x + y * y) / 2, mat.lam * 4 * x * y + 2 * mat.mu * 2 * x * y),
                            dims=(2, 2))
    solid = mesh.Materials("solid")
    mean_gap = ngs.Integrate(scheme.stress - exact, mesh, definedon=solid, order=4)
    scale = ngs.Integrate(ngs.Norm(exact), mesh, definedon=solid, order=4)
    gap = max(abs(g) for g in mean_gap) / scale
    assert (gap < 1e-10) == (initial_stress == "projection"), gap
    assert discrete_divergence(scheme) < 1e-12


def iterative(text: str, limit: str = "") -> str:
    return text.replace('family = "mini"', f'family = "mini"\nsolver = "iterative"{limit}')




def test_a_solve_that_does_not_converge_stops_with_exit_3(tmp_path, capsys):
    text = iterative(CASE.format(T=0.002, every=10), "\nmax_iterations = 2")
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, text=text)), "--out", str(out), "--quiet"]) == 3
    err = capsys.readouterr().err.strip()
    assert "step 1 " in err and "did not reach the tolerance" in err and "\n" not in err, err
    assert json.loads((out / "summary.json").read_text())["status"] == "not converged"


def test_refine_splits_every_cell(tmp_path):
    """``[geometry] refine = 1``: the run's mesh is the generated one refined once (4× the triangles)."""
    from fsivsp.config.production import load_run_case
    coarse = load_run_case(write_case(tmp_path)).mesh
    fine = load_run_case(write_case(tmp_path, text=CASE.format(T=0.002, every=10).replace(
        "maxh = 0.1", "maxh = 0.1\nrefine = 1"))).mesh
    assert fine.ne == 4 * coarse.ne and fine.nv > coarse.nv


def test_large_example_runs_on_its_coarse_mesh(tmp_path):
    """examples/large_ball_3d.toml (1.64 million unknowns, BENCHMARKS.md) is a valid case: its coarse mesh
    (refine = 0) runs its two steps with the iterative solver (PETSc's)."""
    text = (Path(__file__).parents[2] / "examples" / "large_ball_3d.toml").read_text()
    assert "refine = 4" in text
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, text=text.replace("refine = 4", "refine = 0"))), "--out", str(out),
                 "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and summary["step"] == 2 and summary["solver"]["method"] == "petsc"
    assert summary["l2_norms"]["velocity"] > 0
