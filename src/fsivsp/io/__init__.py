"""Output of production runs: VTK time series with a ParaView collection, point and
line probes written as CSV, surface quantities (flow, pressure, force; the interface's traction and wall shear
stress), energy and probe plots, and a JSON summary.

Every file is written next to its final name and moved into place with
``os.replace``, so an interrupted run never leaves a half-written file where a
good one was (the VTK series, the ``.pvd`` collection, the CSV files, the plots).

    fields, stress = scheme_fields(scheme)
    series = VTKSeries(out, scheme.spaces.mesh, fields, refresh=stress)
    probes = Probes(scheme.spaces.mesh, points=[(0.2, 0.2)], lines=[((0, 0.2), (2.5, 0.2), 50)])
    for _ in range(steps):
        scheme.step()
        probes.record(scheme)
        series.write(scheme.time, scheme.n)
    probes.write_csv(out)
"""
from __future__ import annotations

from .plots import LABELS, energy_plot, line_plot, probe_plot, surface_plot, write_summary
from .probes import Probes, bounding_box
from .quantities import REGIONS, SYMMETRIC, SolidStress, region_cf, scheme_fields, symmetric_tensor, von_mises
from .surfaces import Surfaces, SurfaceTable
from .vtk import HOME, VTKSeries, postprocess

__all__ = ["HOME", "LABELS", "REGIONS", "SYMMETRIC", "Probes", "SolidStress", "SurfaceTable", "Surfaces", "VTKSeries",
           "bounding_box", "energy_plot", "line_plot", "postprocess", "probe_plot", "region_cf", "scheme_fields",
           "surface_plot", "symmetric_tensor", "von_mises", "write_summary"]
