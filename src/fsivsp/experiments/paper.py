"""The numerical experiment of Section 5.3, the paper's Tables 1–8 and its runs (``fsivsp paper --all``: in
parallel processes, `run_jobs`)."""
from __future__ import annotations

import csv
import math
import multiprocessing
import signal
from importlib import resources

import numpy as np

from ..config.case import Case, Discretisation
from ..geometry import CHANNEL_HEIGHT, CHANNEL_WIDTH, DISK_CENTRE, DISK_RADIUS, paper_channel
from ..model.manufactured import ExactSolution
from ..model.materials import Materials
from ..solvers import SolverSpec
from ..timestepping.schemes import BDF2, Theta

#: Exact solution (75); the displacement u = ∫ v dt + u⁰ with u⁰ = v(0), so that σ_S n = σ_F n on the circle.
VELOCITY = ["2*x*y*exp(t)", "(x**2 - y**2)*exp(t)"]
PRESSURE = "((x - 0.2)**2 + (y - 0.2)**2 - 0.05**2)*exp(t)"
DISPLACEMENT = VELOCITY
MATERIALS = Materials(rho_fluid=1.0, rho_solid=1.0, nu=0.5, lam=1.0, mu=0.5)
TIME_STEPS = (1e-1, 1e-2, 1e-3, 1e-4)
T_FINAL = 1.0


def paper_case(dt: float, initial_stress: str = "displacement", project_refinement: bool = False,
               solver: SolverSpec | None = None, initial_velocity: str = "interpolation",
               time_scheme: Theta | BDF2 = Theta()) -> Case:
    """The experiment of Section 5.3 with MINI elements and time step ``dt`` (backward Euler, or
    ``time_scheme``), solved by ``solver`` (None: the default `SolverSpec`)."""
    return Case(
        name=f"paper dt={dt:g}",
        coarse_mesh=paper_channel,
        materials=MATERIALS,
        exact=ExactSolution.parse(VELOCITY, PRESSURE, DISPLACEMENT, dim=2, field="paper"),
        T=T_FINAL,
        dt=dt,
        discretisation=Discretisation(initial_stress=initial_stress, initial_velocity=initial_velocity,
                                      project_refinement=project_refinement),
        solver=SolverSpec() if solver is None else solver,
        time_scheme=time_scheme,
    )


def reference_table(dt: float) -> list[dict]:
    """The paper's errors (Tables 1–4) for ``dt``, from the package's copy of the CSV."""
    text = resources.files("fsivsp").joinpath("data/paper_tables.csv").read_text()
    rows = csv.DictReader(line for line in text.splitlines() if not line.startswith("#"))
    table = []
    for row in rows:
        if math.isclose(float(row["dt"]), dt):
            table.append({
                "level": int(row["level"]), "vertices": int(row["vertices"]), "dofs": int(row["dof"]),
                "errors": {"v1": float(row["e_v1"]), "v2": float(row["e_v2"]), "p": float(row["e_p"]),
                           "sigma": float(row["e_sigma"]), "total": float(row["e_total"])},
            })
    return table


def stress_time_floor(dt: float) -> float:
    """Estimated backward-Euler floor of e(σ): the boundary displacement is a Riemann sum of the
    prescribed velocity, so σ_h ≈ σ(t_n) + c (e^{t_n} − 1) ε(V) with c = Δt e^{Δt}/(e^{Δt} − 1) − 1,
    V = v(·, 0) and 2μ = 1; the floor is c ‖ε(V)‖_{L²(Ω_S)} (Δt Σ_n (e^{t_n} − 1)²)^{1/2}."""
    c = dt * math.exp(dt) / math.expm1(dt) - 1
    t = dt * np.arange(1, round(T_FINAL / dt) + 1)
    # ‖ε(V)‖² = ∫ 8(x² + y²) over the channel minus the disk (centre c0, radius r).
    width, height, c0, r = CHANNEL_WIDTH, CHANNEL_HEIGHT, DISK_CENTRE, DISK_RADIUS
    channel = 8 * (width**3 * height / 3 + width * height**3 / 3)
    disk = 8 * (math.pi * r**4 / 2 + 2 * c0**2 * math.pi * r**2)
    return 2 * MATERIALS.mu * c * math.sqrt(channel - disk) * math.sqrt(dt * np.sum(np.expm1(t) ** 2))


def paper_job(job: tuple[float, int, dict]) -> dict:
    """One (Δt, level) run of the paper's experiment (a worker of ``paper --all``)."""
    from ..geometry import refined
    from ..runtime.threads import using
    from .study import run_level

    dt, level, options = job
    case = paper_case(dt, **options)
    with using(case.solver.threads):
        record = run_level(case, refined(case.coarse_mesh(), level, case.discretisation.project_refinement), level)
    record["dt"] = dt
    return record


def thread_lock_bars() -> None:
    """In a worker: tqdm's lock a thread lock (its default's semaphores are reported leaked when Ctrl-C ends it)."""
    import threading

    from tqdm import tqdm

    tqdm.set_lock(threading.RLock())


def run_jobs(jobs: list, processes: int, quiet: bool) -> list[dict]:
    """Run independent (Δt, level) jobs on ``processes`` cores, with a progress bar."""
    from ..runtime.progress import tqdm

    if processes == 1:
        return [paper_job(job) for job in tqdm(jobs, disable=quiet, unit="run")]
    context = multiprocessing.get_context("spawn")
    interrupt = signal.signal(signal.SIGINT, signal.SIG_IGN)  # the workers inherit it: Ctrl-C stops this process only
    try:
        pool = context.Pool(processes, initializer=thread_lock_bars)
    finally:
        signal.signal(signal.SIGINT, interrupt)
    with pool:
        return list(tqdm(pool.imap_unordered(paper_job, jobs), total=len(jobs), disable=quiet, unit="run"))
