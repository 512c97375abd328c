"""The figures of docs/validation.md, "Outlets, inflows and the wall": the artery's P(t) and Q(t) through its inflow and
outflow (examples/artery_3d.toml over three cardiac cycles), its wall shear stress at peak systole on the unrolled
interface, and the pressure wave at the inlet of a compliant channel with a traction-free and a tuned Windkessel
outlet (the set-up of tests/experiments/test_reflection.py at its fine resolution).

Run: PYTHONPATH=src python benchmarks/artery_figures.py [OUT]   (about 10 minutes on 2 cores; OUT default docs/figures)
"""
import json
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
import numpy as np  # noqa: E402

import fsivsp  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
MMHG = 1333.2


def artery(folder: Path) -> Path:
    """examples/artery_3d.toml over three cycles, the interface's fields every 0.02 s."""
    out = folder / "artery3d"
    fsivsp.run(ROOT / "examples" / "artery_3d.toml", out=out, quiet=True,
               overrides={"time.T": 2.4, "output.every": 10, "checkpoint.every": 1200})
    return out


def pressure_and_flow(out: Path, figure: Path) -> dict:
    table = np.genfromtxt(out / "surfaces.csv", delimiter=",", names=True)
    t = table["time"]
    fig, (left, right) = plt.subplots(1, 2, figsize=(9, 3.4), constrained_layout=True)
    left.plot(t, -table["inflowflow"], label="inflow (imposed)")
    left.plot(t, table["outflowflow"], "--", label="outflow")
    left.set_ylabel("Q (cm³/s)")
    right.plot(t, table["inflowpressure"] / MMHG, label="inflow")
    right.plot(t, table["outflowpressure"] / MMHG, "--", label="outflow")
    right.set_ylabel("mean pressure (mmHg)")
    for ax in (left, right):
        ax.set_xlabel("t (s)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("examples/artery_3d.toml: flow-rate inflow (Womersley), RCR outlet, two-layer wall on tissue support",
                 fontsize=9)
    fig.savefig(figure, dpi=110)
    plt.close(fig)
    last = t > 1.6
    return {"pressure_mmHg_last_cycle": [float(table["outflowpressure"][last].min() / MMHG),
                                         float(table["outflowpressure"][last].max() / MMHG)],
            "flow_last_cycle": [float(table["outflowflow"][last].min()), float(table["outflowflow"][last].max())]}


def wall_shear_stress(out: Path, figure: Path) -> dict:
    """|τ| on the interface unrolled (x, θ) at the output step of the last cycle with the largest inflow."""
    table = np.genfromtxt(out / "surfaces.csv", delimiter=",", names=True)
    entries = [line for line in (out / "vtk" / "interface.pvd").read_text().splitlines() if "<DataSet" in line]
    times = [float(line.split('timestep="')[1].split('"')[0]) for line in entries]
    files = [line.split('file="')[1].split('"')[0] for line in entries]
    flows = np.interp(times, table["time"], -table["inflowflow"])
    k = int(np.argmax(np.where(np.array(times) > 1.6, flows, -np.inf)))
    mesh = meshio.read(out / "vtk" / files[k])
    x, y, z = mesh.points.T
    theta = np.degrees(np.arctan2(z, y))
    magnitude = np.asarray(mesh.point_data["wss_magnitude"]).ravel()
    triangles = mesh.cells[0].data
    whole = np.ptp(theta[triangles], axis=1) < 180  # not across the seam θ = ±180°
    fig, ax = plt.subplots(figsize=(8, 3.2), constrained_layout=True)
    dots = ax.tripcolor(x, theta, triangles[whole], facecolors=magnitude[triangles[whole]].mean(axis=1),
                        cmap="viridis")
    fig.colorbar(dots, label="|wall shear stress| (dyn/cm²)")
    ax.set_ylim(-180, 180)
    ax.set_xlabel("x (cm)")
    ax.set_ylabel("θ (degrees)")
    ax.set_title(f"wall shear stress at t = {times[k]:.2f} s (inflow {flows[k]:.1f} cm³/s), vtk/interface.pvd",
                 fontsize=9)
    fig.savefig(figure, dpi=110)
    plt.close(fig)
    poiseuille = 4 * 0.04 * flows[k] / (np.pi * 0.3**3)
    return {"time": times[k], "wss_median": float(np.median(magnitude)), "poiseuille_4nuQ_piR3": float(poiseuille)}


def reflection(figure: Path) -> dict:
    """The backward wave P₋ = (P − Z Q)/2 at the inlet of the compliant channel (L = 10, maxh 0.05, Δt 5e-4) with a
    traction-free and a tuned outlet."""
    from experiments.test_reflection import IMPEDANCE, SPEED, T0, tuned
    from experiments.test_reflection import reflection as measure

    traces = {label: measure(outlets, 10.0, 0.05, 5e-4, trace=True)
              for label, outlets in (("traction-free outlet", {}), ("Windkessel, R_p = Z", tuned()))}
    fig, ax = plt.subplots(figsize=(7, 3.4), constrained_layout=True)
    for label, (back, incident, (t, wave)) in traces.items():
        ax.plot(t, wave / incident, label=f"{label}: max |P₋| {back / incident:.3f} of the incident")
    ax.axvline(T0 + 20 / SPEED, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("t")
    ax.set_ylabel("P₋ / max P₊ at the inlet")
    ax.set_title(f"the reflected wave at the inlet, (P − ZQ)/2 (c = {SPEED:.1f}, Z = {IMPEDANCE:.1f}; dotted: "
                 "t₀ + 2L/c)", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(figure, dpi=110)
    plt.close(fig)
    return {label: back / incident for label, (back, incident, _) in traces.items()}


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "figures"
    target.mkdir(parents=True, exist_ok=True)
    out = artery(Path(tempfile.mkdtemp()))
    record = {"artery": pressure_and_flow(out, target / "artery_pq.png"),
              "wss": wall_shear_stress(out, target / "artery_wss.png"),
              "reflection": reflection(target / "reflection.png")}
    print(json.dumps(record, indent=2))
