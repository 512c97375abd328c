"""Rates in Δt of backward Euler, θ = 1/2 and BDF2 (`fsivsp.experiments.verification.TIME_TABLE`): exact fields
that are not linear in t but lie in the Taylor–Hood k = 1 spaces (straight elements), so the spatial
error vanishes; the rate of the last pair of time steps, 0.025 → 0.0125, for every unknown."""
import pytest

from fsivsp.experiments.verification import TIME_TABLE, run_time

PARAMS = [pytest.param(e, id=e.label, marks=[pytest.mark.slow] if e.slow else []) for e in TIME_TABLE]


@pytest.mark.parametrize("entry", PARAMS)
def test_rate_in_time(entry):
    rates, records = run_time(entry)
    # the spatial error is nil: the errors fall with Δt over three orders of magnitude for order 2
    assert records[0]["errors"]["total"] / records[-1]["errors"]["total"] > 2 ** (3 * entry.order - 1)
    off = {name: rate for name, rate in rates.items() if name != "total" and abs(rate - entry.order) > entry.tolerance}
    assert not off, (entry.label, rates)
