"""analysis.scanner_fit: the direct PI model recovered from a synthetic
loop, its residual on a loop no PI model made, Kuhnen's inverse in double
precision, the card's integers, and the loop file's errors."""
import numpy as np
import pytest

from analysis import scanner_fit as sf

R = 10e6      # pm: a +-10 um axis
ORIGIN = 3e6


def loop_commands(amplitudes=(1.0, 0.6, 0.3, 1.0), steps=800):
    """Full and minor loops about the origin, in the order driven."""
    k = np.arange(steps)
    return np.concatenate([ORIGIN + a * R * np.sin(2 * np.pi * k / steps) for a in amplitudes])


def test_the_fit_recovers_the_weights_of_a_pi_loop():
    x = loop_commands()
    r = np.arange(8) * R / 8
    w = np.array([0.56, 0.13, 0.09, 0.07, 0.055, 0.045, 0.035, 0.025])
    y = ORIGIN + 250.0 + sf.pi_model(x - ORIGIN, r, w)   # an offset of 250 pm
    fit = sf.fit_pi(x, y, 8, origin_pm=ORIGIN)
    assert fit["range_pm"] == pytest.approx(R)
    assert np.allclose(fit["r_pm"], r)
    assert np.allclose(fit["w"], w, atol=1e-9)
    assert fit["offset_pm"] == pytest.approx(250.0, abs=1e-3)
    assert fit["worst_pm"] < 1e-3


def test_a_loop_no_pi_model_made_is_fitted_within_1_5_percent_of_the_range():
    """A Bouc-Wen-like loop (a smooth hysteresis, a piezo's: the slope after a
    reversal 0.81, rising to 1.05): the PI fit's residual."""
    x = loop_commands()
    h, y = 0.0, np.empty(len(x))
    for i in range(len(x)):
        dx = x[i] - x[i - 1] if i else 0.0
        h += 0.12 * dx - 2.0 / R * abs(dx) * h
        y[i] = 1.05 * x[i] - h
    fit = sf.fit_pi(x, y, 8)
    assert fit["worst_pm"] < 0.015 * R   # measured 0.95 %, rms 0.26 %
    assert fit["rms_pm"] < 0.005 * R
    assert all(wi >= 0 for wi in fit["w"])


def test_kuhnens_inverse_undoes_the_direct_model():
    x = loop_commands() - ORIGIN
    r = np.arange(8) * R / 8
    w = np.array([0.56, 0.13, 0.09, 0.07, 0.055, 0.045, 0.035, 0.025])
    ri, wi = sf.inverse_pi(r, w)
    back = sf.pi_model(sf.pi_model(x, r, w), ri, wi)
    assert np.max(np.abs(back - x)) < 1e-6


def test_card_params_are_the_cards_integers():
    fit = {"r_pm": [0.0, 1250000.4], "w": [0.5, 0.25], "range_pm": 2.5e6, "origin_pm": -1.6}
    card = sf.card_params(fit)
    assert card == {"n": 2, "r_pm": [0, 1250000], "w_q24": [1 << 23, 1 << 22], "range_pm": 2500000,
                    "origin_pm": -2, "partial_sums": [0.5, 0.75]}


def test_the_loop_file_names_a_missing_column_and_a_bad_number(tmp_path):
    p = tmp_path / "loop.csv"
    p.write_text("commanded_pm,position\n1,2\n")
    with pytest.raises(ValueError, match="no column measured_pm"):
        sf.read_loop(str(p))
    p.write_text("commanded_pm,measured_pm\n1,2\n3,x\n")
    with pytest.raises(ValueError, match="line 3: not a number"):
        sf.read_loop(str(p))
    assert sf.main([str(p)]) == 2


def test_the_command_line_prints_the_fit(tmp_path, capsys):
    x = loop_commands(steps=200)
    y = ORIGIN + sf.pi_model(x - ORIGIN, np.arange(4) * R / 4, [0.7, 0.1, 0.1, 0.1])
    p = tmp_path / "loop.csv"
    p.write_text("commanded_pm,measured_pm\n" + "".join(f"{a},{b}\n" for a, b in zip(x, y)))
    assert sf.main([str(p), "--plays", "4"]) == 0
    out = capsys.readouterr().out
    assert "4 plays" in out and "w 0.700000" in out
