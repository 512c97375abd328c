"""The frequency domain's test cases, as case files for `fsivsp harmonic`/`fsivsp modes` and their time-domain twins
for `fsivsp run`, and a fresh Python process for what needs PETSc with complex scalars (one build per process: a
test worker may hold the real one)."""
import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: ρ_F = ρ_S = 1, ν = 0.1, λ = 2, μ = 1: the cases of the prototype (issue 35), lightly damped modes near 1.48.
MATERIALS = """
[materials]
rho_fluid = 1.0
rho_solid = 1.0
nu = 0.1
lam = 2.0
mu = 1.0
"""

#: The unit box of fluid on a solid (MINI): the top of ``fluid_wall`` moves with (16x²(1−x)², 0) cos(ωt − 90°) (the
#: expression vanishes on the fluid's sides), a body force (0.5, −x) cos ωt acts on the solid. Probes in the fluid,
#: near Γ, on Γ and in the solid.
LID = """
[geometry]
kind = "fluid_over_solid"
dim = 2
maxh = 0.1
""" + MATERIALS + """
[discretisation]
family = "mini"

[data]
force_solid = ["0.5", "-x"]

[boundary.fluid_wall]
velocity = ["16*x**2*(1 - x)**2*(2*y - 1)", "0"]
phase = 90

[output]
vtk = false
probes = [[0.5, 0.75], [0.3, 0.55], [0.5, 0.5], [0.7, 0.25]]
"""

#: A 2D elastic tube (Taylor–Hood k = 1): a pressure (traction −p n, p = 1 − y²/4) at the inflow, phase 45°, the
#: wall's ends clamped, its outside and the outflow free; a body force (y, 0) on the fluid.
TUBE = """
[geometry]
kind = "elastic_tube"
dim = 2
maxh = 0.15
length = 2.0
radius = 0.5
wall = 0.2
""" + MATERIALS + """
[discretisation]
family = "taylor_hood"

[data]
force_fluid = ["y", "0"]

[boundary.inflow]
traction = ["1 - y**2/4", "0"]
phase = 45

[boundary.solid_ends]
velocity = ["0", "0"]

[boundary.solid_wall]
traction = ["0", "0"]

[output]
vtk = false
probes = [[0.5, 0.0], [1.0, 0.3], [1.0, 0.5], [1.5, 0.6]]
"""


def harmonic_case(text: str, frequencies: list[float]) -> dict:
    """The harmonic case of ``text`` at ``frequencies``."""
    return {**tomllib.loads(text), "harmonic": {"frequencies": frequencies}}


def time_domain_case(text: str, frequency: float, T: float, dt: float, ramp: float | None = None) -> dict:
    """The run case of the harmonic case ``text``: every datum g(x) with phase φ (degrees) as g(x) cos(2πft − φ),
    times the ramp 1 − exp(−(t/ramp)²) if given (a smooth start excites little of the lightly damped modes), from
    rest, Crank–Nicolson with step ``dt`` up to ``T``."""
    case = tomllib.loads(text)
    omega = 2 * 3.141592653589793 * frequency
    envelope = f"(1 - exp(-(t/{ramp!r})**2))*" if ramp else ""

    def timed(values, phase=0.0):
        return [f"{envelope}cos({omega!r}*t - {phase * 3.141592653589793 / 180!r})*({value})" for value in values]

    case["data"] = {key: timed(values) for key, values in case.get("data", {}).items()}
    for spec in case.get("boundary", {}).values():
        phase = spec.pop("phase", 0.0)
        for kind in ("velocity", "traction"):
            if kind in spec:
                spec[kind] = timed(spec[kind], phase)
    case["time"] = {"T": T, "dt": dt, "scheme": "theta", "theta": 0.5}
    return case


def complex_process(code: str, timeout: float = 300) -> dict:
    """Run ``code`` in a fresh Python with this checkout's sources, PETSc and SLEPc with complex scalars loaded
    first; its last line of output is JSON, returned."""
    prelude = "from fsivsp.solvers.petsc_init import use\nuse('complex')\n"
    done = subprocess.run([sys.executable, "-c", prelude + code], capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, PYTHONPATH=str(ROOT / "src"), FSIVSP_THREADS="1"))
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


def fsivsp(*args: str) -> subprocess.CompletedProcess:
    """``fsivsp ARGS`` in a fresh Python (``fsivsp modes`` loads PETSc with complex scalars) with this checkout's
    sources, on one thread."""
    return subprocess.run([sys.executable, "-m", "fsivsp", *map(str, args)], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT / "src"), FSIVSP_THREADS="1"))
