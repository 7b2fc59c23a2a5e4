"""Triaxial profiles from a breakpoint table file and from a command-line string (SPEC 1.6, 3).

Reference values: SPEC 3's NAVMAT P-9492 check value (6.06 g rms by the log-log area formula),
the closed-form area of a power-law segment, and IEEE 1293's mount-angle geometry.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vrelab.profiles import RandomProfile, parse_profile
from vrelab.triaxial.files import parse_triaxial, read_triaxial, write_triaxial
from vrelab.triaxial.profile import PairCoherence, TriaxialProfile, TriaxialSine

NAVMAT = """[x]
breakpoints = [[20, 0.01], [80, 0.04], [350, 0.04], [2000, 0.007]]
"""


def _write(tmp_path: Path, text: str, name: str = "p.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_axes_on_the_union_of_breakpoints_are_exact(tmp_path):
    # z: one power-law segment n = 1 (0.01 g²/Hz at 20 Hz, 1 at 2000): at 80 and 350 Hz it is
    # 0.01·f/20 exactly, and its area P1·f1/(n+1)·((f2/f1)^(n+1) - 1) = 999.9 g² (SPEC 3)
    p = _write(tmp_path, NAVMAT + "[z]\nbreakpoints = [[20, 0.01], [2000, 1.0]]\n")
    prof = read_triaxial(p)
    assert prof.freq_hz.tolist() == [20.0, 80.0, 350.0, 2000.0]
    np.testing.assert_allclose(prof.axis_psd_g2_per_hz[:, 2], [0.01, 0.04, 0.175, 1.0], rtol=1e-13)
    assert prof.axis_psd_g2_per_hz[:, 0].tolist() == [0.01, 0.04, 0.04, 0.007]  # its own values, bit for bit
    rms = np.sqrt(prof.axis_mean_square_g2)
    assert rms[0] == pytest.approx(6.06, abs=0.005)  # SPEC 3 check value
    assert rms[1] == 0.0  # no [y]: still
    assert rms[2] == pytest.approx(math.sqrt(0.01 * 20 / 2 * (100.0**2 - 1)), rel=1e-12)
    assert prof.grms == pytest.approx(math.hypot(rms[0], rms[2]), rel=1e-12)
    # pairs not given are incoherent
    assert np.all(prof.coherency[:, 0, 2] == 0)


def test_coherence_and_phase_tables_linear_in_ln_f(tmp_path):
    p = _write(tmp_path, NAVMAT + "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n"
               "[pair.xz]\ncoherence = [[20, 0.9], [2000, 0.1]]\nphase_deg = [[20, 0.0], [200, 45.0], [2000, 90.0]]\n")
    prof = read_triaxial(p)
    assert prof.freq_hz.tolist() == [20.0, 80.0, 200.0, 350.0, 2000.0]  # the tables' breakpoints join the union
    c = prof.coherency[:, 0, 2]
    x = np.log(prof.freq_hz / 20.0) / math.log(100.0)  # position in ln f across the band
    np.testing.assert_allclose(np.abs(c) ** 2, 0.9 - 0.8 * x, rtol=1e-12)
    np.testing.assert_allclose(np.degrees(np.angle(c)), 90.0 * x, atol=1e-10)
    np.testing.assert_allclose(prof.coherency[:, 2, 0], np.conj(c))  # Hermitian


def test_pair_seen_from_the_other_axis_negates_the_phase(tmp_path):
    body = NAVMAT + "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n"
    a = read_triaxial(_write(tmp_path, body + "[pair.xz]\ncoherence = 0.5\nphase_deg = 30\n", "a.toml"))
    b = read_triaxial(_write(tmp_path, body + "[pair.zx]\ncoherence = 0.5\nphase_deg = -30\n", "b.toml"))
    np.testing.assert_allclose(a.coherency, b.coherency, atol=1e-15)
    assert np.degrees(np.angle(a.coherency[0, 0, 2])) == pytest.approx(30.0)


def test_file_round_trip(tmp_path):
    src = _write(tmp_path, "[triaxial]\nname = \"rt\"\n" + NAVMAT + "[y]\nstart = [20, 0.005]\nslopes = [[2000, -3.0]]\n"
                 "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n[pair.xy]\ncoherence = 0.3\nphase_deg = -120\n"
                 "[pair.yz]\ncoherence = [[20, 0.2], [2000, 0.6]]\n")
    a = read_triaxial(src)
    out = write_triaxial(a, tmp_path / "out.toml")
    b = read_triaxial(out)
    assert b.name == "rt"
    assert np.array_equal(a.freq_hz, b.freq_hz)
    assert np.array_equal(a.axis_psd_g2_per_hz, b.axis_psd_g2_per_hz)
    np.testing.assert_allclose(b.coherency, a.coherency, atol=1e-14)
    assert "coherence = 0.3" in out.read_text()  # a constant stays one
    assert not list(tmp_path.glob(".*partial"))  # atomic: no temporary left behind


def test_rank_one_profile_along_a_direction_round_trips(tmp_path):
    prof = TriaxialProfile.along(RandomProfile.flat(20, 2000, grms=3.0), [1.0, 0.0, -1.0])
    back = read_triaxial(write_triaxial(prof, tmp_path / "along.toml"))
    np.testing.assert_allclose(back.csd([100.0]), prof.csd([100.0]), atol=1e-15)
    assert back.grms == pytest.approx(3.0, rel=1e-12)


def test_parse_along_a_direction_and_a_mount_angle():
    # IEEE 1293 mount angle: axis z at 45° toward x -> (sin 45°, 0, cos 45°)
    a = parse_triaxial("flat:20-2000@z45x")
    b = parse_triaxial("flat:20-2000@dir=1,0,1")
    np.testing.assert_allclose(a.csd([100.0]), b.csd([100.0]), atol=1e-15)
    x = parse_triaxial("flat:20-2000@x")
    assert np.sqrt(x.axis_mean_square_g2).tolist() == pytest.approx([math.sqrt(1980.0), 0.0, 0.0])
    # -30° from x toward y: the y component negative, the cross-spectrum negative
    m = parse_triaxial("20:0.01,2000:0.01@x-30y")
    s = m.csd([100.0])[0]
    assert s[0, 1].real == pytest.approx(-0.01 * math.cos(math.radians(30)) * math.sin(math.radians(30)))
    sine = parse_triaxial("sine:80:0.5@z90y")
    assert isinstance(sine, TriaxialSine)
    assert sine.direction == pytest.approx((0.0, 1.0, 0.0))
    assert sine.rms_g == 0.5


def test_single_axis_parse_profile_unchanged():
    assert parse_profile("flat:20-2000") == RandomProfile.flat(20, 2000, name="flat-20-2000",
                                                               source="flat (unit PSD shape)")
    with pytest.raises(ValueError):
        parse_profile("flat:20-2000@z45x")  # the single-axis parser does not take a direction


@pytest.mark.parametrize("body, words", [
    (NAVMAT + "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n[pair.xz]\ncoherence = 1.2\n", "within 0..1"),
    (NAVMAT + "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n[pair.xz]\ncoherence = -0.1\n", "within 0..1"),
    (NAVMAT + "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n[pair.xz]\ncoherence = nan\n", "finite"),
    (NAVMAT + "[z]\nbreakpoints = [[20, -0.02], [2000, 0.02]]\n", "axis z: psd_g2_per_hz must be > 0"),
    (NAVMAT + "[z]\nbreakpoints = [[200, 0.02], [20, 0.02]]\n", "non-monotonic"),
    (NAVMAT + "[z]\nbreakpoints = [[50, 0.02], [2000, 0.02]]\n", "same band"),
    (NAVMAT + "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n[pair.xz]\ncoherence = [[20, 0.5], [10, 0.5]]\n",
     "non-monotonic"),
    (NAVMAT + "[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n[pair.xz]\ncoherence = [[50, 0.5], [2000, 0.5]]\n",
     "not the whole band"),
    # x and y fully coherent, x and z fully coherent, but y and z incoherent: no vibration does that
    (NAVMAT + "[y]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n[z]\nbreakpoints = [[20, 0.02], [2000, 0.02]]\n"
     "[pair.xy]\ncoherence = 1.0\n[pair.xz]\ncoherence = 1.0\n[pair.yz]\ncoherence = 0.0\n", "inconsistent"),
    (NAVMAT + "[pair.xz]\ncoherence = 0.5\n", "still"),
    ("[profile]\nbreakpoints = [[20, 0.01], [2000, 0.01]]\n", "give a direction"),
    (NAVMAT + "[w]\nbreakpoints = [[20, 0.01], [2000, 0.01]]\n", "unknown table"),
])
def test_bad_files_are_one_clear_line(tmp_path, body, words):
    p = _write(tmp_path, body)
    with pytest.raises(ValueError) as exc:
        read_triaxial(p)
    msg = str(exc.value)
    assert words in msg and "\n" not in msg and str(p) in msg


def test_non_hermitian_coherency_refused():
    c = np.broadcast_to(np.eye(3, dtype=complex), (2, 3, 3)).copy()
    c[:, 0, 1] = 0.5
    c[:, 1, 0] = 0.4
    with pytest.raises(ValueError, match="Hermitian"):
        TriaxialProfile([20.0, 2000.0], np.full((2, 3), 0.01), c)
    with pytest.raises(ValueError, match="within 0..1"):
        PairCoherence.constant(1.5)


@pytest.mark.parametrize("spec, words", [
    ("flat:20-2000@dir=0,0,0", "zero vector"),
    ("flat:20-2000@dir=1,nan,0", "three finite numbers"),
    ("flat:20-2000@q45x", "give dir=X,Y,Z"),
    ("flat:20-2000@z45z", "two different axes"),
    ("flat:20-2000", "needs a direction"),
    ("@x", "give a profile before"),
    ("sine:abc@x", "sine:F"),
])
def test_bad_specs(spec, words):
    with pytest.raises(ValueError, match=words):
        parse_triaxial(spec)


def test_cli_profile_writes_and_refuses(tmp_path, capsys):
    env = {**os.environ}
    out = tmp_path / "mount.toml"
    run = subprocess.run([sys.executable, "-m", "vrelab", "profile", "flat:20-2000@z45x", "--grms", "3",
                          "--write", str(out), "--json"], capture_output=True, text=True, env=env)
    assert run.returncode == 0, run.stderr
    back = read_triaxial(out)
    assert back.grms == pytest.approx(3.0, rel=1e-12)
    np.testing.assert_allclose(np.sqrt(back.axis_mean_square_g2), [3 / math.sqrt(2), 0, 3 / math.sqrt(2)])
    from vrelab.cli import main

    assert main(["profile", "flat:20-2000@dir=0,0,0"]) == 2  # in-process: a subprocess costs seconds
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "zero vector" in err and "Traceback" not in err


def test_a_still_axis_has_no_coherence_in_to_dict_or_describe() -> None:
    # along x-z at 45° (y still): a still axis's coherence is undefined (0/0), so to_dict says
    # null and describe names only the moving pair; the internal matrix stays a valid coherency
    prof = parse_triaxial("flat:20-2000@z45x")
    d = prof.to_dict()
    for m in range(len(d["freq_hz"])):
        for j, k in ((0, 1), (1, 0), (1, 1), (1, 2), (2, 1)):
            assert d["coherence"][m][j][k] is None and d["phase_deg"][m][j][k] is None
        assert d["coherence"][m][0][2] == pytest.approx(1.0) and d["phase_deg"][m][0][2] == pytest.approx(0.0)
    text = prof.describe()
    assert "coherence xz 1" in text and "xy" not in text and "yz" not in text
    TriaxialProfile(prof.freq_hz, prof.axis_psd_g2_per_hz, prof.coherency)  # still positive semi-definite
    # per-axis profiles with y still and an x-z coherence of 0.3: the same rule
    band = RandomProfile(np.array([20.0, 500.0]), np.array([1e-3, 1e-3]))
    two = TriaxialProfile.from_axes({"x": band, "z": band}, coherence={("x", "z"): (0.3, 20.0)}).to_dict()
    assert two["coherence"][0][0][1] is None and two["coherence"][0][0][2] == pytest.approx(0.3)
    assert two["phase_deg"][0][2][0] == pytest.approx(-20.0)
