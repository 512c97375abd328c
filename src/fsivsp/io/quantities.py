"""The fields a run writes (`VTKSeries`) and their ParaView forms: the region array, the solid stress as a
symmetric tensor, its von Mises value, the displacement only in the solid."""
from __future__ import annotations

import ngsolve as ngs

from ..geometry import FLUID, SOLID, Phases
from ..runtime.threads import sequential

#: ``region`` values in the VTU files (point and cell data, for ParaView's Threshold)
REGIONS = {FLUID: 0, SOLID: 1}

def _components(tensor: ngs.CoefficientFunction, dim: int) -> ngs.CoefficientFunction:
    """A d×d matrix as the row-major vector (σ_11, σ_12, …, σ_dd)."""
    return ngs.CF(tuple(tensor[i, j] for i in range(dim) for j in range(dim)))


#: ParaView's symmetric-tensor order XX, YY, ZZ, XY, YZ, XZ as (row, column) pairs
SYMMETRIC = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))


def symmetric_tensor(tensor: ngs.CoefficientFunction, dim: int) -> ngs.CoefficientFunction:
    """A symmetric d×d matrix as ParaView's 6-component tensor (XX, YY, ZZ, XY, YZ, XZ); in 2D the
    z components are 0 (the in-plane stress)."""
    return ngs.CF(tuple(tensor[i, j] if i < dim and j < dim else 0 for i, j in SYMMETRIC))


class SolidStress:
    """σ_h copied into a plain (L²)^{d·d} GridFunction of the same order on Ω_S (exact: the same
    polynomials per component). VTKOutput evaluates the symmetric matrix-valued space through a
    generic fallback that prints "called base class apply" at every point; this copy does not."""

    def __init__(self, scheme):
        mesh, self.scheme, self.dim = scheme.spaces.mesh, scheme, scheme.spaces.mesh.dim
        order = scheme.spaces.stress.globalorder
        with sequential():
            solid = mesh.Materials(scheme.spaces.phases.pattern(SOLID))
            self.values = ngs.GridFunction(ngs.L2(mesh, order=order, definedon=solid)
                                           ** (self.dim ** 2))

    def __call__(self) -> None:
        self.values.Set(_components(self.scheme.stress, self.dim))


def von_mises(stress: ngs.CoefficientFunction, materials, dim: int) -> ngs.CoefficientFunction:
    """sqrt(3/2 s:s) with s the deviatoric part of the (3D) stress.

    In 2D the stress is completed to 3D by plane strain (ε_zz = 0, so
    σ_zz = λ tr ε = λ/(2(λ+μ)) (σ_xx + σ_yy), σ_xz = σ_yz = 0); then
    s:s = σ:σ + σ_zz² − (tr σ + σ_zz)²/3.
    """
    contraction = ngs.InnerProduct(stress, stress)
    trace = ngs.Trace(stress)
    if dim == 2:
        zz = materials.lam / (2 * (materials.lam + materials.mu)) * trace
        contraction = contraction + zz * zz
        trace = trace + zz
    deviatoric = contraction - trace * trace / 3
    return ngs.sqrt(1.5 * ngs.IfPos(deviatoric, deviatoric, 0))


def scheme_fields(scheme) -> tuple[dict[str, ngs.CoefficientFunction], SolidStress]:
    """The fields of a `Scheme` for `VTKSeries`, and the `SolidStress` to refresh before writing.

    ``velocity`` (d components), ``pressure`` (the fluid pressure, 0 in the solid),
    ``stress`` (the solid stress σ as ParaView's symmetric tensor XX YY ZZ XY YZ XZ, 0 in the fluid),
    ``von_mises`` (see `von_mises`, 0 in the fluid), ``displacement`` (the solid displacement, d components,
    0 in the fluid: the scheme's integrated velocity there is no displacement) and ``region`` (0 fluid, 1 solid).
    """
    mesh, phases = scheme.spaces.mesh, scheme.spaces.phases
    dim = mesh.dim
    stress = SolidStress(scheme)
    sigma = ngs.CF(stress.values, dims=(dim, dim))
    fields = {
        "velocity": scheme.velocity,
        "pressure": scheme.pressure,
        "stress": symmetric_tensor(sigma, dim),
        "von_mises": von_mises(sigma, scheme.coefficients, dim),
        "displacement": mesh.MaterialCF({phases.pattern(SOLID): 1}, default=0) * scheme.displacement,
        "region": region_cf(mesh, phases),
    }
    return fields, stress


def region_cf(mesh: ngs.Mesh, phases: Phases = Phases()) -> ngs.CoefficientFunction:
    """0 in the fluid, 1 in the solid (`REGIONS`)."""
    return mesh.MaterialCF({phases.pattern(medium): value for medium, value in REGIONS.items()}, default=-1)
