"""The discrete spaces of Section 5.2: V_h (global velocity), Q_h (fluid pressure),
S_h (solid stress), and the product V_h × Q_h of step 1 of the scheme (5.1); with complex values for the
frequency domain, periodic (NGSolve's ``Periodic``) on a mesh with periodic identifications.

With a solid pressure (``solid_pressure = "continuous"``, docs/solvers.md "The solid pressure") the step's
unknowns are V_h × Q_h × P_h: P_h continuous P_k on Ω_S (k = 1 for MINI, whose V_h then carries the cell bubble
on the solid cells too), so that (V_h|_S, P_h) is the Stokes-stable pair of the fluid's element and the solid does
not lock as λ/μ grows."""
from __future__ import annotations

from dataclasses import dataclass

import ngsolve as ngs

from ..geometry import FLUID, FLUID_WALL, SOLID, SOLID_WALL, Phases, is_periodic, locked_fluid_cells
from ..model.materials import Materials
from ..runtime.threads import sequential

FAMILIES = ("mini", "taylor_hood")

#: The values of ``[discretisation] solid_pressure``: ``"auto"`` is `resolve_solid_pressure`'s choice.
SOLID_PRESSURES = ("auto", "none", "continuous")

#: ``"auto"`` keeps a solid pressure where some solid region has λ ≥ this × μ (Poisson's ratio ≥ 0.4545…). The
#: paper's case (λ/μ = 2), every example (at most 9: the artery's Poisson 0.45) and the tests stay below it, so
#: the default leaves their discretisation as the paper's; at λ/μ = 10² the paper's discretisation already loses
#: a factor 2–3 in e(σ) on level 3 (docs/verification.md, "Locking").
AUTO_LOCKING_RATIO = 10.0


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
    solid_pressure: ngs.FESpace | None = None  #: P_h on Ω_S (None: the paper's scheme, X_h = V_h × Q_h)

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
    def solid_bonus_intorder(self) -> int:
        """`bonus_intorder` on the solid cells: nonzero only where they carry bubbles (MINI with a solid pressure)."""
        return self.bonus_intorder if self.solid_pressure is not None and self.family == "mini" else 0

    @property
    def mesh(self) -> ngs.Mesh:
        return self.velocity.mesh

    @property
    def periodic(self) -> bool:
        """Whether V_h and Q_h are periodic (`build_spaces`)."""
        return isinstance(self.velocity, ngs.Periodic)

    def free_dofs(self) -> int:
        """Unknowns of the saddle-point solve (velocity and pressures, Dirichlet dofs excluded)."""
        return global_count(self.mixed, self.mixed.FreeDofs())


def global_count(space: ngs.FESpace, dofs: ngs.BitArray) -> int:
    """How many of the dofs set in ``dofs`` the space has: on a distributed mesh (MPI) over all ranks, each
    dof shared by ranks counted once."""
    shared = space.ParallelDofs()
    if shared is None:
        return dofs.NumSet()
    return round(space.mesh.comm.Sum((dofs & shared.MasterDofs()).NumSet()))


def resolve_solid_pressure(choice: str, materials: Materials, phases: Phases = Phases()) -> str:
    """``"none"`` or ``"continuous"``: ``choice`` itself, or for ``"auto"`` ``"continuous"`` where some solid region of
    ``phases`` has λ ≥ `AUTO_LOCKING_RATIO` μ (the defaults count where no region has its own materials)."""
    if choice not in SOLID_PRESSURES:
        raise ValueError(f"solid_pressure: expected one of {', '.join(SOLID_PRESSURES)}, got {choice!r}")
    if choice != "auto":
        return choice
    solids = [materials.of(region) for region in phases.solid] or [materials]
    return "continuous" if any(m.lam >= AUTO_LOCKING_RATIO * m.mu for m in solids) else "none"


def velocity_space(mesh: ngs.Mesh, family: str, order: int, dirichlet: str,
                   phases: Phases = Phases(), complex: bool = False,
                   solid_bubbles: bool = False) -> tuple[ngs.FESpace, int]:
    """V_h and the order of its cell bubbles (0 if none).

    MINI (72): continuous P1 plus the bubble of degree d+1 on fluid cells only, so that
    ε(V_h) restricted to the solid is piecewise constant (condition (18)); with ``solid_bubbles`` (a solid
    pressure, where (18) is not needed) on every cell.
    Taylor–Hood: continuous P_{k+1} on Ω; fluid cells with all vertices on Dirichlet walls
    (`locked_fluid_cells`) get the bubble of degree d+1 too when P_{k+1} has no interior dof,
    so that the pressure at such a corner is controlled (a local MINI-type enrichment).
    The bubbles are cell dofs: a periodic wrapper (`build_spaces`) identifies none of them.
    """
    base = base_order(family, order)
    cells = ([el.nr for el in mesh.Elements(ngs.VOL) if solid_bubbles or el.mat in phases.fluid] if family == "mini"
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
                 complex: bool = False, solid_pressure: str = "none") -> Spaces:
    """V_h, Q_h, S_h of the MINI element (5.2.1) or the generalized Taylor–Hood
    element of order k (5.2.2): Q_h continuous P_k on Ω_F, S_h discontinuous P_k
    symmetric tensors on Ω_S (k = 1 and piecewise constants for MINI); Ω_F and Ω_S the cell regions of
    ``phases``.

    ``complex``: V_h and Q_h with complex values (the frequency domain, `frequency`); S_h stays real (NGSolve's
    matrix-valued L² refuses complex values, and no frequency-domain form needs it). On a mesh with periodic
    identifications (`geometry.is_periodic`) V_h and Q_h are NGSolve's ``Periodic`` spaces, which glue the
    identified boundaries.

    ``solid_pressure``: ``"none"`` (the paper's) or ``"continuous"`` (the module's docstring; resolve ``"auto"``
    first, `resolve_solid_pressure`): X_h = V_h × Q_h × P_h, P_h continuous P_k on Ω_S."""
    if family not in FAMILIES:
        raise ValueError(f"family: expected one of {', '.join(FAMILIES)}, got {family!r}")
    if solid_pressure not in SOLID_PRESSURES[1:]:
        raise ValueError(f"solid_pressure: expected one of {', '.join(SOLID_PRESSURES[1:])}, got {solid_pressure!r}")
    if family == "mini":
        order = 1
    extended = solid_pressure == "continuous"
    velocity, bubble = velocity_space(mesh, family, order, dirichlet, phases, complex, solid_bubbles=extended)
    pressure = ngs.H1(mesh, order=order, definedon=phases.pattern(FLUID), complex=complex)
    solid = ngs.H1(mesh, order=order, definedon=phases.pattern(SOLID), complex=complex) if extended else None
    if is_periodic(mesh):
        velocity, pressure = ngs.Periodic(velocity), ngs.Periodic(pressure)
        solid = ngs.Periodic(solid) if extended else None
    stress_order = 0 if family == "mini" else order
    stress = ngs.MatrixValued(ngs.L2(mesh, order=stress_order, definedon=phases.pattern(SOLID)), symmetric=True)
    mixed = velocity * pressure if solid is None else ngs.FESpace([velocity, pressure, solid])
    return Spaces(family, order, velocity, pressure, stress, mixed, bubble, dirichlet, phases, solid)
