"""Vibration profiles (SPEC section 3): grms closed form, validation, files, named profiles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from vrelab.profiles import (
    RandomProfile,
    SineProfile,
    named_profiles,
    parse_profile,
    read_profile,
    write_profile,
)


def quad_grms(prof: RandomProfile) -> float:
    """Independent grms: scipy quad of a log-log interpolant written here, segment by segment."""
    total = 0.0
    f, p = prof.freq_hz, prof.psd_g2_per_hz
    for i in range(len(f) - 1):
        n = math.log(p[i + 1] / p[i]) / math.log(f[i + 1] / f[i])
        area, _ = integrate.quad(lambda x, i=i, n=n: p[i] * (x / f[i]) ** n, f[i], f[i + 1], epsabs=0, epsrel=1e-12)
        total += area
    return math.sqrt(total)


# --- reference values -------------------------------------------------------------------------


def test_navmat_p9492_is_6_06_grms_spec3():
    """SPEC 3 / NAVMAT P-9492: 20 Hz 0.01, 80 Hz 0.04, flat to 350 Hz, -3 dB/oct (n = -1) -> 6.06."""
    prof = parse_profile("navmat-p9492")
    assert prof.grms == pytest.approx(6.06, abs=0.005)
    # Hand sum of the three areas: 0.01·20/2·(4²-1) + 0.04·270 + 0.04·350·ln(2000/350).
    by_hand = math.sqrt(1.5 + 10.8 + 14.0 * math.log(2000 / 350))
    assert prof.grms == pytest.approx(by_hand, rel=1e-12)


def test_navmat_from_slopes_spec3():
    """NAVMAT P-9492 written as start + dB/oct slopes: exact ±3 dB/oct is n = ±0.9966, ≈ 6.05 grms."""
    prof = RandomProfile.from_slopes(20, 0.01, [(80, 3.0), (350, 0.0), (2000, -3.0)])
    assert prof.grms == pytest.approx(6.05, abs=0.01)
    assert prof.slopes_db_per_oct == pytest.approx([3.0, 0.0, -3.0], abs=1e-12)
    assert prof.grms == pytest.approx(quad_grms(prof), rel=1e-10)


def test_breakpoints_20_80_350_2000_give_6_92_grms_spec3():
    """SPEC 3 check value: 20/0.01, 80/0.05, 350/0.05, 2000/0.01 -> 6.92 grms."""
    prof = RandomProfile.from_breakpoints([20, 80, 350, 2000], [0.01, 0.05, 0.05, 0.01])
    assert prof.grms == pytest.approx(6.92, abs=0.005)


def test_gevs_workmanship_6_8_grms():
    """GSFC-STD-7000 (GEVS) minimum workmanship table quotes an overall 6.8 grms."""
    assert parse_profile("gevs-workmanship").grms == pytest.approx(6.8, abs=0.05)


def test_article_flat_profile_band_and_level():
    """The article's flat 50 Hz-2 kHz profile, stored at the datasheet's 2.5 g rms condition."""
    prof = parse_profile("adi-flat-50-2000")
    assert prof.band == (50.0, 2000.0)
    assert prof.grms == pytest.approx(2.5, rel=1e-12)
    assert prof.psd(1000.0) == pytest.approx(2.5**2 / 1950, rel=1e-12)


@pytest.mark.parametrize(
    "f,p",
    [
        ([20, 80, 350, 2000], [0.01, 0.05, 0.05, 0.01]),
        ([10, 100, 1000], [1e-4, 1.0, 1e-3]),  # steep slopes, ±30 dB/dec
        ([50, 2000], [0.02, 0.02]),
        ([100, 400], [0.1, 0.025]),  # exactly n = -1
        ([100, 400], [0.1, 0.025 * (1 + 1e-10)]),  # n + 1 tiny: the stable branch
    ],
)
def test_closed_form_agrees_with_quad(f, p):
    prof = RandomProfile.from_breakpoints(f, p)
    assert prof.grms == pytest.approx(quad_grms(prof), rel=1e-9)


def test_closed_form_continuous_through_n_minus_1():
    """The area is continuous at n = -1: no jump between n = -1 and n = -1 ± 1e-12."""
    f = [100.0, 400.0]
    exact = RandomProfile.from_breakpoints(f, [0.1, 0.025]).mean_square_g2
    assert exact == pytest.approx(0.1 * 100 * math.log(4), rel=1e-14)
    for eps in (1e-12, -1e-12, 1e-7, -1e-7):
        p2 = 0.1 * 4.0 ** (-1 + eps)
        near = RandomProfile.from_breakpoints(f, [0.1, p2]).mean_square_g2
        assert near == pytest.approx(exact, rel=2 * abs(eps) + 1e-13)


def test_psd_log_log_interpolation_and_zero_outside():
    prof = RandomProfile.from_breakpoints([20, 80], [0.01, 0.04])  # n = 1: P = 0.01·f/20
    assert prof.psd(40.0) == pytest.approx(0.02, rel=1e-12)
    assert np.allclose(prof.psd([10.0, 20.0, 80.0, 81.0, -5.0]), [0, 0.01, 0.04, 0, 0])


def test_scaled_to_multiplies_psd_by_ratio_squared():
    prof = parse_profile("navmat-p9492")
    scaled = prof.scaled_to(3.03)
    ratio2 = (3.03 / prof.grms) ** 2
    assert scaled.grms == pytest.approx(3.03, rel=1e-12)
    assert np.allclose(scaled.psd_g2_per_hz, prof.psd_g2_per_hz * ratio2, rtol=1e-14)
    assert np.allclose(scaled.slopes_db_per_oct, prof.slopes_db_per_oct)
    assert prof.grms == pytest.approx(6.06, abs=0.005)  # the original is unchanged


def test_flat_constructor():
    prof = RandomProfile.flat(50, 2000, grms=2.5)
    assert prof.psd_g2_per_hz[0] == pytest.approx(6.25 / 1950)
    assert RandomProfile.flat(50, 2000, psd=0.01).grms == pytest.approx(math.sqrt(19.5))
    with pytest.raises(ValueError, match="not both"):
        RandomProfile.flat(50, 2000, grms=1, psd=1)


def test_describe_and_to_dict():
    prof = RandomProfile.flat(50, 2000, grms=2.5)
    assert prof.describe() == "random 50–2000 Hz, 2.50 g rms"
    # What a test stepping this shape through levels states: the shape, never the level.
    assert prof.describe_shape() == "random 50–2000 Hz"
    d = prof.to_dict()
    assert d["band_hz"] == [50.0, 2000.0] and d["breakpoints"][1][0] == 2000.0
    assert d["slopes_db_per_oct"] == [0.0]


def test_sine_profile():
    s = SineProfile(100.0, 1.0)
    assert s.peak_g == pytest.approx(math.sqrt(2))
    assert SineProfile.from_peak(100, math.sqrt(2)).rms_g == pytest.approx(1.0)
    assert "100 Hz" in s.describe()
    with pytest.raises(ValueError, match="freq_hz"):
        SineProfile(0.0, 1.0)
    with pytest.raises(ValueError, match="rms_g"):
        SineProfile(10.0, -1.0)


# --- validation -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "f,p,match",
    [
        ([20, 350, 80, 2000], [0.01, 0.04, 0.04, 0.007], r"non-monotonic.*breakpoint 2 \(80 Hz\)"),
        ([20, 20, 80], [0.01, 0.02, 0.04], "non-monotonic"),
        ([20, 80], [0.01, -0.04], "psd_g2_per_hz must be > 0"),
        ([20, 80], [0.01, 0.0], "psd_g2_per_hz must be > 0"),
        ([20, 80], [0.01, float("nan")], "NaN"),
        ([20, float("inf")], [0.01, 0.01], "finite"),
        ([20], [0.01], "at least 2 breakpoints"),
        ([-20, 80], [0.01, 0.01], "freq_hz must be > 0"),
        ([20, 80, 100], [0.01, 0.01], "same length"),
    ],
)
def test_validation_errors(f, p, match):
    with pytest.raises(ValueError, match=match):
        RandomProfile.from_breakpoints(f, p)


def test_inputs_not_modified_and_arrays_read_only():
    f = np.array([20.0, 80.0, 350.0])
    p = np.array([0.01, 0.04, 0.04])
    prof = RandomProfile(f, p)
    f[0] = 1.0
    assert prof.freq_hz[0] == 20.0
    with pytest.raises(ValueError):
        prof.psd_g2_per_hz[0] = 5.0
    prof.scaled_to(1.0)
    assert p[0] == 0.01


# --- files and parsing ------------------------------------------------------------------------


@pytest.mark.parametrize("ext", ["csv", "toml"])
def test_file_round_trip(tmp_path, ext):
    prof = RandomProfile.from_breakpoints(
        [20, 80, 350, 2000], [0.01, 0.05, 0.05, 0.01 / 3], name="test", source="unit test"
    )
    path = write_profile(prof, tmp_path / f"p.{ext}")
    back = read_profile(path)
    assert back == prof
    assert not list(tmp_path.glob("*.partial"))


def test_csv_with_header_comments_and_spaces(tmp_path):
    path = tmp_path / "p.csv"
    path.write_text("# a comment\nfreq, psd\n20, 0.01  # inline\n\n80,0.04\n350 ,0.04\n2000,0.007\n")
    assert read_profile(path).grms == pytest.approx(6.06, abs=0.005)


def test_csv_malformed_names_file_and_line(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("f,psd\n20,0.01\n80,abc\n")
    with pytest.raises(ValueError, match=r"bad\.csv: line 3"):
        read_profile(path)
    path.write_text("20,0.01,5\n80,0.02\n")
    with pytest.raises(ValueError, match=r"line 1: expected 2 columns"):
        read_profile(path)
    path.write_text("20,0.01\n10,0.02\n")
    with pytest.raises(ValueError, match=r"bad\.csv: non-monotonic"):
        read_profile(path)


def test_toml_slopes_form(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[profile]\nname = "x"\nstart = [20, 0.01]\nslopes = [[80, 3], [350, 0], [2000, -3]]\n')
    prof = read_profile(path)
    assert prof.name == "x" and prof.grms == pytest.approx(6.05, abs=0.01)


@pytest.mark.parametrize(
    "body,match",
    [
        ("[profile]\nbreakpoints = [[20, 0.01], [80]]\n", r"profile\.breakpoints\[1\]"),
        ("[profile]\nbreakpoints = [[20, 0.01], [80, 'x']]\n", r"profile\.breakpoints\[1\]"),
        ("[other]\nx = 1\n", r"no \[profile\] table"),
        ("[profile]\nstart = [20, 0.01]\n", "start and profile.slopes"),
        ("[profile\n", "not valid TOML"),
        ("[profile]\nbreakpoints = [[20, 0.01], [80, 0.02]]\ngrms = -1\n", "profile.grms"),
    ],
)
def test_toml_malformed_names_file_and_field(tmp_path, body, match):
    path = tmp_path / "bad.toml"
    path.write_text(body)
    with pytest.raises(ValueError, match=match) as info:
        read_profile(path)
    assert "bad.toml" in str(info.value)


def test_parse_profile_forms(tmp_path):
    inline = parse_profile("20:0.01, 80:0.05,350:0.05,2000:0.01")
    assert inline.grms == pytest.approx(6.92, abs=0.005)
    flat = parse_profile("flat:50-2000")
    assert flat.band == (50.0, 2000.0) and flat.psd(100.0) == 1.0
    path = write_profile(inline, tmp_path / "x.csv")
    assert parse_profile(str(path)) == read_profile(path)
    assert set(named_profiles()) >= {"adi-flat-50-2000", "navmat-p9492", "gevs-workmanship"}


@pytest.mark.parametrize("spec", ["nonsense", "", "20:0.01", "flat:2000-50", "flat:abc", "20:0.01,80"])
def test_parse_profile_rejects(spec):
    with pytest.raises(ValueError):
        parse_profile(spec)


def test_parse_profile_unknown_lists_forms():
    with pytest.raises(ValueError, match=r"F:P.*flat:F1-F2.*navmat-p9492"):
        parse_profile("nonsense")


def test_parse_profile_missing_file():
    with pytest.raises(FileNotFoundError):
        parse_profile("/nonexistent/p.csv")


def test_band_is_a_tuple():
    """`profile.band` is the contract: the first and last breakpoint frequencies."""
    prof = parse_profile("navmat-p9492")
    assert prof.band == (20.0, 2000.0)
    lo, hi = prof.band
    assert (lo, hi) == (20.0, 2000.0)


@pytest.mark.parametrize("f_lo,f_hi", [(0.0, 50.0), (30.0, 80.0), (60.0, 400.0), (100.0, 1e4), (2000.0, 3000.0)])
def test_mean_square_between_against_quad(f_lo, f_hi):
    prof = parse_profile("navmat-p9492")
    lo, hi = max(f_lo, 20.0), min(f_hi, 2000.0)
    want = integrate.quad(prof.psd, lo, hi, points=[80, 350], epsrel=1e-12)[0] if hi > lo else 0.0
    assert prof.mean_square_between(f_lo, f_hi) == pytest.approx(want, rel=1e-9, abs=1e-15)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(0.05, 3.0), min_size=1, max_size=5),
    st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6),
    st.floats(1.0, 100.0),
)
def test_closed_form_vs_quad_property(log_steps, log_psd, f0):
    """Any breakpoint table (octave steps, PSD spanning ±3 decades): closed form = quadrature."""
    f = f0 * np.exp(np.cumsum([0.0, *log_steps]))
    p = 10.0 ** np.array(log_psd[: f.size])
    prof = RandomProfile.from_breakpoints(f, p)
    assert prof.grms == pytest.approx(quad_grms(prof), rel=1e-8)


@pytest.mark.parametrize("grms", [1e200, 1.5e5, math.inf])
def test_scaling_refuses_levels_beyond_any_shaker(grms):
    """A level of 1e200 g rms (an exponent slip) once overflowed squaring the ratio; it is refused
    by name, with the bound, before any arithmetic (the bound itself still scales)."""
    flat = RandomProfile.flat(50.0, 2000.0)
    with pytest.raises(ValueError, match="grms must be"):
        flat.scaled_to(grms)
    assert flat.scaled_to(1e5).grms == pytest.approx(1e5, rel=1e-12)
