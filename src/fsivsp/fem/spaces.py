"""The discrete spaces of Section 5.2: V_h (global velocity), Q_h (fluid pressure),
S_h (solid stress), and the product V_h × Q_h of step 1 of the scheme (5.1); with complex values for the
frequency domain, periodic (NGSolve's ``Periodic``) on a mesh with periodic identifications."""
from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs

from ..geometry import FLUID, FLUID_WALL, SOLID, SOLID_WALL, Phases, is_periodic, locked_fluid_cells
from ..runtime.threads import sequential

FAMILIES = ("mini", "taylor_hood")


def base_order(family: str, order: int) -> int:
    """The polynomial degree of V_h without bubbles: 1 for MINI, k + 1 for Taylor–Hood k
    (also the order to which curved elements are mapped)."""
    return 1 if family == "mini" else order + 1


@dataclass
class Spaces:
    """V_h, Q_h, S_h and X_h = V_h × Q_h on one mesh."""

    family: str
    order: int
    velocity: ngs.FESpace
    pressure: ngs.FESpace
    stress: ngs.FESpace
    mixed: ngs.FESpace
    bubble_order: int = 0
    dirichlet: str = ""  #: the boundaries where the velocity is prescribed ("a|b")
    phases: Phases = Phases()  #: the cell regions of Ω_F and Ω_S

    @property
    def velocity_order(self) -> int:
        """The largest polynomial degree in V_h (bubbles included)."""
        return max(base_order(self.family, self.order), self.bubble_order)

    @property
    def bonus_intorder(self) -> int:
        """NGSolve 6.2.2608 integrates a tetrahedron by its face/edge order, not the order of a
        cell-only bubble: without this bonus, ∇ of the quartic bubble is sampled at the centroid."""
        base = base_order(self.family, self.order)
        return 2 * (self.bubble_order - base) if self.bubble_order and self.mesh.dim == 3 else 0

    @property
    def mesh(self) -> ngs.Mesh:
        return self.velocity.mesh

    @property
    def periodic(self) -> bool:
        """Whether V_h and Q_h are periodic (`build_spaces`)."""
        return isinstance(self.velocity, ngs.Periodic)

    def free_dofs(self) -> int:
        """Unknowns of the saddle-point solve (velocity and pressure, Dirichlet dofs excluded)."""
        return global_count(self.mixed, self.mixed.FreeDofs())


def global_count(space: ngs.FESpace, dofs: ngs.BitArray) -> int:
    """How many of the dofs set in ``dofs`` the space has: on a distributed mesh (MPI) over all ranks, each
    dof shared by ranks counted once."""
    shared = space.ParallelDofs()
    if shared is None:
        return dofs.NumSet()
    return round(space.mesh.comm.Sum((dofs & shared.MasterDofs()).NumSet()))


def velocity_space(mesh: ngs.Mesh, family: str, order: int, dirichlet: str,
                   phases: Phases = Phases(), complex: bool = False) -> tuple[ngs.FESpace, int]:
    """V_h and the order of its cell bubbles (0 if none).

    MINI (72): continuous P1 plus the bubble of degree d+1 on fluid cells only, so that
    ε(V_h) restricted to the solid is piecewise constant (condition (18)).
    Taylor–Hood: continuous P_{k+1} on Ω; fluid cells with all vertices on Dirichlet walls
    (`locked_fluid_cells`) get the bubble of degree d+1 too when P_{k+1} has no interior dof,
    so that the pressure at such a corner is controlled (a local MINI-type enrichment).
    The bubbles are cell dofs: a periodic wrapper (`build_spaces`) identifies none of them.
    """
    base = base_order(family, order)
    cells = ([el.nr for el in mesh.Elements(ngs.VOL) if el.mat in phases.fluid] if family == "mini"
             else locked_fluid_cells(mesh, dirichlet, phases))
    space = ngs.VectorH1(mesh, order=base, dirichlet=dirichlet, complex=complex)
    bubble = mesh.dim + 1
    if base >= bubble or not mesh.comm.Sum(len(cells)):  # on any rank (Update is collective under MPI)
        return space, 0
    for nr in cells:
        space.SetOrder(ngs.NodeId(ngs.CELL, nr), bubble)
    space.Update()
    return space, bubble


@sequential()   # the same element colouring in every process (threaded assembly adds in its order)
def build_spaces(mesh: ngs.Mesh, family: str = "mini", order: int = 1,
                 dirichlet: str = f"{FLUID_WALL}|{SOLID_WALL}", phases: Phases = Phases(),
                 complex: bool = False) -> Spaces:
    """V_h, Q_h, S_h of the MINI element (5.2.1) or the generalized Taylor–Hood
    element of order k (5.2.2): Q_h continuous P_k on Ω_F, S_h discontinuous P_k
    symmetric tensors on Ω_S (k = 1 and piecewise constants for MINI); Ω_F and Ω_S the cell regions of
    ``phases``.

    ``complex``: V_h and Q_h with complex values (the frequency domain, `frequency`); S_h stays real (NGSolve's
    matrix-valued L² refuses complex values, and no frequency-domain form needs it). On a mesh with periodic
    identifications (`geometry.is_periodic`) V_h and Q_h are NGSolve's ``Periodic`` spaces, which glue the
    identified boundaries."""
    if family not in FAMILIES:
        raise ValueError(f"family: expected one of {', '.join(FAMILIES)}, got {family!r}")
    if family == "mini":
        order = 1
    velocity, bubble = velocity_space(mesh, family, order, dirichlet, phases, complex)
    pressure = ngs.H1(mesh, order=order, definedon=phases.pattern(FLUID), complex=complex)
    if is_periodic(mesh):
        velocity, pressure = ngs.Periodic(velocity), ngs.Periodic(pressure)
    stress_order = 0 if family == "mini" else order
    stress = ngs.MatrixValued(ngs.L2(mesh, order=stress_order, definedon=phases.pattern(SOLID)), symmetric=True)
    return Spaces(family, order, velocity, pressure, stress, velocity * pressure, bubble, dirichlet, phases)
