"""Issue 12's second parameter set: a stiff solid (λ = μ = 100 ν) and a large step (Δt = 0.25) in the 3D solid
ball, MINI. σ lags its rate on levels 1→2 (0.81) while v and p converge at theirs; docs/verification.md has
levels 0–4 (σ at 0.95 from level 3 to 4: pre-asymptotic) and the best approximation. This pins the
measurement: if σ starts converging at 0.9 or more on these levels, or v and p stop converging, the page is
stale."""
from pathlib import Path

from fsivsp.config.case import load_study_case
from fsivsp.experiments.study import study

EXAMPLE = Path(__file__).parents[2] / "examples" / "stiff_solid_in_fluid_3d.toml"


def test_stress_lags_with_a_stiff_solid_and_a_large_step():
    records = study(load_study_case(EXAMPLE), range(0, 3))
    rates = records[2]["rates"]
    assert 0.7 < rates["sigma"] < 0.9, rates  # measured 0.807
    assert min(rates["v1"], rates["v2"], rates["v3"]) > 1.1 and rates["p"] > 2.5, rates  # 1.16-1.21, 3.08
