"""Rates for every element family, dimension and configuration (the verification matrix).

One table (fsivsp.experiments.verification.TABLE): family, order, dim, configuration → expected rate;
one parametrised test, in the spirit of scikit-fem's tests/test_convergence.py. The exact
solutions (examples/*.toml) have v independent of t and u linear in t, so backward Euler
adds no time error and the rates are the spatial ones: k + 1 for Taylor–Hood k (v in H¹,
p and σ in L²), 1 for MINI.
"""
import pytest

from fsivsp.experiments.verification import SHORT_OF_EXPECTED, TABLE, run, worst

#: Entries that `make test` runs on their first two levels only (the rate of that pair, against the same expected
#: rate), `make test-all` on the table's three as well: the three levels of these cost 8–23 s each, the first two
#: 1–2 s. Worst rates measured on levels 0–1: 1.867, 2.011, 1.908 (expected ≥ 1.85). MINI in 3D is not here: on
#: levels 0–1 its worst rates are 0.86–0.90, short of 0.95 (pre-asymptotic), so it keeps its three levels.
TWO_LEVELS = {"TH1-3d-fluid_in_solid", "TH1-3d-fluid_over_solid", "TH1-3d-solid_in_fluid"}


def marks(entry, slow=None):
    found = [pytest.mark.slow] if (entry.slow if slow is None else slow) else []
    if entry.label in SHORT_OF_EXPECTED:
        found.append(pytest.mark.xfail(strict=True, reason=SHORT_OF_EXPECTED[entry.label]))
    return found


def two_levels(entry) -> range:
    return range(entry.levels.start, entry.levels.start + 2)


PARAMS = [pytest.param(e, e.levels, id=e.label, marks=marks(e, e.slow or e.label in TWO_LEVELS)) for e in TABLE] + \
         [pytest.param(e, two_levels(e), id=f"{e.label}-levels{two_levels(e).start}-{two_levels(e).stop - 1}",
                       marks=marks(e)) for e in TABLE if e.label in TWO_LEVELS]


def test_two_level_entries_are_in_the_table():
    assert TWO_LEVELS <= {e.label for e in TABLE if not e.slow}


@pytest.mark.parametrize("entry, levels", PARAMS)
def test_rate(entry, levels):
    rates, records = run(entry, levels)
    assert worst(rates) >= entry.expected, (entry.label, levels, rates)
