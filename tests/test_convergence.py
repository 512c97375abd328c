"""Rates for every element family, dimension and configuration (the verification matrix).

One table (fsivsp.verification.TABLE): family, order, dim, configuration → expected rate;
one parametrised test, in the spirit of scikit-fem's tests/test_convergence.py. The exact
solutions (examples/*.toml) have v independent of t and u linear in t, so backward Euler
adds no time error and the rates are the spatial ones: k + 1 for Taylor–Hood k (v in H¹,
p and σ in L²), 1 for MINI.
"""
import pytest

from fsivsp.verification import SHORT_OF_EXPECTED, TABLE, run, worst


def marks(entry):
    found = [pytest.mark.slow] if entry.slow else []
    if entry.label in SHORT_OF_EXPECTED:
        found.append(pytest.mark.xfail(strict=True, reason=SHORT_OF_EXPECTED[entry.label]))
    return found


PARAMS = [pytest.param(e, id=e.label, marks=marks(e)) for e in TABLE]


@pytest.mark.parametrize("entry", PARAMS)
def test_rate(entry):
    rates, records = run(entry)
    assert worst(rates) >= entry.expected, (entry.label, rates)
