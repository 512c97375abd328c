"""The verification matrix: element family × order × dimension × configuration → measured rates.

Each entry runs the manufactured case ``examples/<configuration>_<d>d.toml`` (v independent
of t and u linear in t, so backward Euler adds no time error) with the entry's element on
three uniformly refined meshes, and fits the rate (76) by least squares.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

CONFIGURATIONS = ("fluid_in_solid", "fluid_over_solid", "solid_in_fluid")
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@dataclasses.dataclass(frozen=True)
class Entry:
    family: str
    order: int
    dim: int
    configuration: str
    slow: bool = False
    first_level: int | None = None  # overrides the rule of `levels`

    @property
    def levels(self) -> range:
        """Three levels: 1–3 in 2D (level 0 is pre-asymptotic); in 3D 0–2, except 1–3 for MINI and
        Taylor–Hood k = 1 around a ball (their level-0 meshes have a handful of cells in the ball);
        from ``first_level`` where the table says so."""
        if self.first_level is not None:
            first = self.first_level
        elif self.dim == 3 and (self.configuration == "fluid_over_solid" or self.order >= 2):
            first = 0
        else:
            first = 1
        return range(first, first + 3)

    @property
    def expected(self) -> float:
        """The rate the theory predicts, minus the tolerance: k + 1 − 0.15 for TH_k, 0.95 for MINI."""
        return 0.95 if self.family == "mini" else self.order + 1 - 0.15

    @property
    def label(self) -> str:
        element = "MINI" if self.family == "mini" else f"TH{self.order}"
        return f"{element}-{self.dim}d-{self.configuration}"


def _entries() -> list[Entry]:
    table = []
    for configuration in CONFIGURATIONS:
        ball = configuration != "fluid_over_solid"
        # MINI in the enclosed fluid ball: the pressure is pre-asymptotic until level 3 (per-pair rates
        # 0.84 on 2→3, 1.06 on 3→4; level 4 has 120 721 vertices, 11 minutes).
        mini_3d_first = 2 if configuration == "fluid_in_solid" else None
        table += [Entry("mini", 1, 2, configuration), Entry("taylor_hood", 1, 2, configuration),
                  Entry("taylor_hood", 2, 2, configuration), Entry("taylor_hood", 3, 2, configuration, slow=True),
                  Entry("mini", 1, 3, configuration, slow=ball, first_level=mini_3d_first),
                  Entry("taylor_hood", 1, 3, configuration, slow=ball),
                  Entry("taylor_hood", 2, 3, configuration, slow=True)]
    return table


TABLE = _entries()

#: Entries measured below their expected rate (make test-all, this machine), kept as strict xfails:
#: if one starts passing, the test suite says so.
SHORT_OF_EXPECTED = {
    "TH1-3d-fluid_in_solid": "levels 1-3: v 1.91-1.97, p 1.71 (enclosed fluid ball)",
    "TH2-3d-fluid_in_solid": "levels 0-2: v 2.67-2.94, p 2.94; levels 1-3 are beyond this machine's budget",
    "TH2-3d-solid_in_fluid": "levels 0-2: v 2.71-2.95, p 3.40; levels 1-3 are beyond this machine's budget",
}


def fitted_rates(records: list[dict], dim: int) -> dict[str, float]:
    """r = −d · slope of log e against log N, least squares over the levels."""
    logn = np.log([r["vertices"] for r in records])
    return {key: float(-dim * np.polyfit(logn, np.log([r["errors"][key] for r in records]), 1)[0])
            for key in records[0]["errors"]}


def run(entry: Entry, levels: range | None = None, examples: Path = EXAMPLES) -> tuple[dict[str, float], list[dict]]:
    """Fitted rates and the per-level records of one entry."""
    from .case import load_study_case, to_study
    from .study import study

    case_file = load_study_case(examples / f"{entry.configuration}_{entry.dim}d.toml")
    case = dataclasses.replace(to_study(case_file), family=entry.family, order=entry.order)
    records = study(case, entry.levels if levels is None else levels)
    return fitted_rates(records, entry.dim), records


def markdown(results: list[tuple[Entry, dict[str, float]]]) -> str:
    """The matrix as a Markdown table (minimum over the unknowns, then each unknown)."""
    head = ("| element | d | configuration | levels | expected ≥ | min | v | p | σ |\n"
            "|---|---|---|---|---|---|---|---|---|")
    rows = []
    for entry, rates in results:
        velocity = min(v for k, v in rates.items() if k.startswith("v"))
        measured = [velocity, rates["p"], rates["sigma"]]
        element = "MINI" if entry.family == "mini" else f"Taylor–Hood k={entry.order}"
        levels = f"{entry.levels.start}–{entry.levels.stop - 1}"
        rows.append(f"| {element} | {entry.dim} | {entry.configuration} | {levels} | {entry.expected:.2f} | "
                    f"{min(measured):.2f} | " + " | ".join(f"{r:.2f}" for r in measured) + " |")
    return "\n".join([head] + rows)


def worst(rates: dict[str, float]) -> float:
    """The smallest rate over the unknowns (the total excluded)."""
    return min(v for k, v in rates.items() if k != "total" and math.isfinite(v))
