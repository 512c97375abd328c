"""docs/cases.md cannot drift: its table is `config.keys.KEYS` rendered, and the keys there are exactly the keys the
readers accept (a new key without a row, or a row of a key no reader takes, fails here)."""
import importlib.util
from pathlib import Path

import pytest

from fsivsp.config import boundaries, case, frequency, production
from fsivsp.config.keys import KEYS, names
from fsivsp.geometry import KINDS

ROOT = Path(__file__).resolve().parents[2]


def test_the_page_is_the_list():
    spec = importlib.util.spec_from_file_location("cases_table", ROOT / "tools" / "cases_table.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    text = tool.PAGE.read_text()
    assert tool.rendered(text) == text, ("docs/cases.md differs from fsivsp.config.keys.KEYS: "
                                         "python tools/cases_table.py")


ACCEPTED = {
    "geometry": {"kind", "dim", "maxh", "refine"} | {name for kind in KINDS.values() for name in kind["parameters"]},
    "materials": case.SECTIONS["materials"] | {"young", "poisson"},
    "materials.NAME": set(case.FLUID_FIELDS) | set(case.SOLID_FIELDS) | {"young", "poisson"},
    "time": case.SECTIONS["time"],
    "discretisation": case.SECTIONS["discretisation"],
    "solver": case.SECTIONS["solver"],
    "exact": case.SECTIONS["exact"],
    "data": production.DATA_KEYS,
    "boundary.NAME": boundaries.BOUNDARY_KEYS | {frequency.PHASE},
    "output": production.OUTPUT_KEYS,
    "checkpoint": production.CHECKPOINT_KEYS,
    "harmonic": frequency.HARMONIC_KEYS,
    "modes": frequency.MODES_KEYS,
}


@pytest.mark.parametrize("section", sorted(ACCEPTED))
def test_every_accepted_key_is_documented_and_no_other(section):
    assert names(section) == ACCEPTED[section]


def test_every_section_is_on_the_page():
    assert {key.section for key in KEYS} == set(ACCEPTED)
    sections = production.RUN_SECTIONS | {"exact"} | set(frequency.USED["harmonic"]["sections"]) | {"modes"}
    assert sections == {section.split(".")[0] for section in ACCEPTED}
