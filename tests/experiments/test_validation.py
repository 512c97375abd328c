"""Physical validation (issue 4): the pressure pulse in an elastic tube, and the helpers that
measure its speed (`fsivsp.validation`)."""
import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fsivsp.app.loop import run_case
from fsivsp.config.production import load_run_case
from fsivsp.experiments.moens_korteweg import (
    arrival_time,
    arrival_times,
    moens_korteweg,
    read_probe_pressures,
    wave_speed,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


# -- Moens–Korteweg ------------------------------------------------------------------------


def test_moens_korteweg_for_the_example_tube():
    # sqrt(3e6 * 0.1 / (2 * 1 * 0.5 * 0.91)) = sqrt(329670.3...)
    assert moens_korteweg(3e6, 0.1, 1.0, 0.5, 0.3) == pytest.approx(574.1692, rel=1e-6)


def test_moens_korteweg_scalings():
    c = moens_korteweg(3e6, 0.1, 1.0, 0.5)
    assert c == pytest.approx(math.sqrt(3e6 * 0.1 / (2 * 1.0 * 0.5)))  # ν_P = 0: E h / (2 ρ R)
    assert moens_korteweg(12e6, 0.1, 1.0, 0.5) == pytest.approx(2 * c)
    assert moens_korteweg(3e6, 0.4, 1.0, 0.5) == pytest.approx(2 * c)
    assert moens_korteweg(3e6, 0.1, 4.0, 0.5) == pytest.approx(c / 2)
    assert moens_korteweg(3e6, 0.1, 1.0, 2.0) == pytest.approx(c / 2)
    assert moens_korteweg(3e6, 0.1, 1.0, 0.5, 0.3) == pytest.approx(c / math.sqrt(1 - 0.09))


@pytest.mark.parametrize("args", [(0, 0.1, 1, 0.5, 0.3), (3e6, -0.1, 1, 0.5, 0.3), (3e6, 0.1, math.nan, 0.5, 0.3),
                                  (3e6, 0.1, 1, 0, 0.3), (3e6, 0.1, 1, 0.5, 0.5), (3e6, 0.1, 1, 0.5, -1)])
def test_moens_korteweg_refuses_unphysical_input(args):
    with pytest.raises(ValueError):
        moens_korteweg(*args)


# -- wave speed and arrival times ------------------------------------------------------------


def test_wave_speed_of_exact_arrivals():
    x = [1.0, 2.0, 3.0, 4.0]
    assert wave_speed(x, [0.003 + xi / 574.0 for xi in x]) == pytest.approx(574.0)
    assert wave_speed([4.0, 1.0], [0.01, 0.0]) == pytest.approx(300.0)  # order does not matter


def test_wave_speed_is_the_least_squares_fit_of_the_times():
    rng = np.random.default_rng(0)
    x = np.linspace(1.0, 4.0, 7)
    t = 0.002 + x / 500.0 + rng.normal(0.0, 5e-5, x.size)
    slope = np.polyfit(x, t, 1)[0]
    assert wave_speed(x, t) == pytest.approx(1 / slope)
    assert wave_speed(x, t) == pytest.approx(500.0, rel=0.05)


@pytest.mark.parametrize("x, t", [([1.0], [0.1]), ([1.0, 2.0], [0.1]), ([1.0, 1.0], [0.1, 0.2]),
                                  ([1.0, 2.0], [0.1, 0.1]), ([1.0, math.inf], [0.1, 0.2])])
def test_wave_speed_refuses_degenerate_input(x, t):
    with pytest.raises(ValueError):
        wave_speed(x, t)


def test_arrival_time_interpolates_the_first_crossing():
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    p = np.array([0.0, 2.0, 6.0, 10.0, 0.0])
    assert arrival_time(t, p) == pytest.approx(1.75)  # 5 = half of 10, between 2 (t=1) and 6 (t=2)
    assert arrival_time(t, p, fraction=1.0) == pytest.approx(3.0)
    assert arrival_time(t, p, fraction=0.2) == pytest.approx(1.0)
    with pytest.raises(ValueError):
        arrival_time(t, -p)  # no positive pulse
    with pytest.raises(ValueError):
        arrival_time(t, p, fraction=0.0)


def write_probes(path: Path, time, pressures, dim=2):
    columns = ["step", "time"] + [f"p{i}_{n}" for i in range(len(pressures))
                                  for n in [f"v{k + 1}" for k in range(dim)] + ["p"]]
    lines = [",".join(columns)]
    for n, t in enumerate(time):
        row = [str(n), repr(float(t))]
        for p in pressures:
            row += ["0.0"] * dim + [repr(float(p[n]))]
        lines.append(",".join(row))
    path.write_text("\n".join(lines) + "\n")


def test_arrival_times_recover_a_travelling_gaussian(tmp_path):
    """Gaussian pulses delayed by x / c (and attenuated): the half-maximum arrivals move at c."""
    c, tau, dt = 500.0, 0.002, 1e-4
    time = np.arange(0.0, 0.03, dt)
    positions = [1.0, 2.0, 3.0, 4.0]
    pressures = [(1 - 0.1 * x) * np.exp(-((time - 0.006 - x / c) / tau) ** 2) for x in positions]
    write_probes(tmp_path / "probes.csv", time, pressures, dim=3)
    times = arrival_times(tmp_path / "probes.csv")
    expected = [0.006 + x / c - tau * math.sqrt(math.log(2)) for x in positions]
    assert times == pytest.approx(expected, abs=0.01 * dt)  # linear interpolation: ~2.5e-7 s here
    assert wave_speed(positions, times) == pytest.approx(c, rel=1e-3)
    t, p = read_probe_pressures(tmp_path / "probes.csv")
    assert p.shape == (len(time), 4) and t[1] == pytest.approx(dt)


# -- the pressure wave ----------------------------------------------------------------------


def probe_positions(case_file: Path) -> list[float]:
    return [point[0] for point in tomllib.loads(case_file.read_text())["output"]["probes"]]


def substitute(text: str, key: str, value: str) -> str:
    text, count = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
    assert count == 1, key
    return text


def test_2d_pressure_wave_propagates(tmp_path):
    """The 2D channel's flexural wave reaches the probes one after the other (a coarsened copy
    of examples/pressure_wave_2d.toml: maxh 0.1, dt 5e-5 change its arrival times by < 0.15 ms)."""
    example = EXAMPLES / "pressure_wave_2d.toml"
    text = substitute(example.read_text(), "maxh", "0.1")
    text = substitute(text, "dt", "5.0e-5")
    text = text.replace("[output]", "[output]\nvtk = false")
    case_file = tmp_path / "wave2d.toml"
    case_file.write_text(text)
    out = tmp_path / "out"
    assert run_case(load_run_case(case_file), out, quiet=True)["status"] == "completed"
    positions = probe_positions(example)
    times = arrival_times(out / "probes.csv")
    assert positions == sorted(positions) and len(times) == len(positions) >= 3
    assert all(a < b for a, b in zip(times, times[1:])), times
    assert wave_speed(positions, times) > 0


@pytest.mark.slow
def test_3d_pressure_wave_moves_at_the_moens_korteweg_speed(tmp_path):
    """The 3D example (about 2 minutes): within 20 % of Moens–Korteweg (measured: 0.85)."""
    example = EXAMPLES / "pressure_wave.toml"
    case_file = tmp_path / "wave3d.toml"
    case_file.write_text(example.read_text().replace("[output]", "[output]\nvtk = false"))
    out = tmp_path / "out"
    case = load_run_case(case_file)
    assert run_case(case, out, quiet=True)["status"] == "completed"
    doc = tomllib.loads(example.read_text())
    geometry, materials = doc["geometry"], doc["materials"]
    c_mk = moens_korteweg(materials["young"], geometry["wall"], materials["rho_fluid"], geometry["radius"],
                          materials["poisson"])
    speed = wave_speed(probe_positions(example), arrival_times(out / "probes.csv"))
    assert abs(speed / c_mk - 1) < 0.2, (speed, c_mk)
