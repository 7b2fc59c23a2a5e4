"""Sine-on-random (SPEC 6.2): the profile type, its syntax and files, its level and scaling rule.

Reference values: a tone's mean square is peak²/2 (a sine's rms is peak/√2) and uncorrelated
components add in mean square; NAVMAT P-9492's random part is 6.06 g rms (SPEC 3).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vrelab.cli import main
from vrelab.profiles import (
    RandomProfile,
    SineOnRandom,
    Tone,
    parse_profile,
    read_profile,
    write_profile,
)

NAVMAT_TONES = "navmat-p9492+sine:120:0.5,240:0.2"


def test_grms_adds_the_tones_mean_square():
    """NAVMAT (6.0582 g rms, SPEC 3) + 0.5 and 0.2 g peak tones: √(6.0582² + 0.5²/2 + 0.2²/2)."""
    p = parse_profile(NAVMAT_TONES)
    assert isinstance(p, SineOnRandom)
    navmat_ms = 1.5 + 10.8 + 14.0 * math.log(2000 / 350)  # the hand sum of test_profiles
    assert p.grms == pytest.approx(math.sqrt(navmat_ms + 0.125 + 0.02), rel=1e-12)
    assert [t.rms_g for t in p.tones] == pytest.approx([0.5 / math.sqrt(2), 0.2 / math.sqrt(2)], rel=1e-15)
    assert p.band == (20.0, 2000.0) and p.name == "navmat-p9492"


def test_band_widens_to_tones_outside_the_random_band():
    p = parse_profile("flat:50-2000+sine:30:1,2400:0.1")
    assert p.band == (30.0, 2400.0) and p.random.band == (50.0, 2000.0)


def test_scaling_rule_scales_random_and_tones_together():
    """To reach a target grms: PSD × (target/grms)², each tone amplitude × target/grms; the share
    of the tones in the mean square is unchanged."""
    p = parse_profile(NAVMAT_TONES)
    q = p.scaled_to(2.0)
    r = 2.0 / p.grms
    assert q.grms == pytest.approx(2.0, rel=1e-12)
    assert np.allclose(q.random.psd_g2_per_hz, p.random.psd_g2_per_hz * r**2, rtol=1e-14)
    assert [t.peak_g for t in q.tones] == pytest.approx([0.5 * r, 0.2 * r], rel=1e-14)
    assert q.tone_mean_square_g2 / q.mean_square_g2 == pytest.approx(p.tone_mean_square_g2 / p.mean_square_g2, rel=1e-12)


def test_to_dict_keeps_the_profile_contract_keys():
    d = parse_profile(NAVMAT_TONES).to_dict()
    assert {"grms", "breakpoints", "band_hz", "name", "source", "tones", "random_grms"} <= set(d)
    assert d["kind"] == "sine-on-random" and d["tones"][0] == {"freq_hz": 120.0, "peak_g": 0.5, "rms_g": 0.5 / math.sqrt(2)}


def test_toml_tone_tables_round_trip(tmp_path):
    path = tmp_path / "sor.toml"
    path.write_text('[profile]\nname = "pump"\nbreakpoints = [[20, 0.01], [2000, 0.01]]\n'
                    '[[tone]]\nfreq_hz = 50\npeak_g = 1.0\n[[tone]]\nfreq_hz = 100\npeak_g = 0.25\n')
    p = read_profile(path)
    assert isinstance(p, SineOnRandom) and p.name == "pump"
    assert p.grms == pytest.approx(math.sqrt(0.01 * 1980 + 0.5 + 0.25**2 / 2), rel=1e-12)
    out = write_profile(p, tmp_path / "back.toml")
    assert read_profile(out) == p
    assert parse_profile(f"{path}+sine:300:0.1").tones[-1] == Tone(300.0, 0.1)  # a file's tones, plus more
    with pytest.raises(ValueError, match=r"\.toml"):
        write_profile(p, tmp_path / "back.csv")


@pytest.mark.parametrize("body, words", [
    ("[[tone]]\nfreq_hz = 50\n", r"tone\[0\]: peak_g is missing"),
    ("[[tone]]\nfreq_hz = 50\npeak_g = -1\n", r"tone\[0\]: tone at 50 Hz: amplitude must be >= 0"),
    ("[[tone]]\nfreq_hz = 0\npeak_g = 1\n", r"tone\[0\]: tone frequency must be a finite number > 0"),
    ("[[tone]]\nfreq_hz = 50\npeak_g = 1\nphase = 3\n", r"tone\[0\]: unknown key 'phase'"),
    ("tone = 5\n", "tone must be"),
])
def test_toml_bad_tones_name_file_and_table(tmp_path, body, words):
    path = tmp_path / "bad.toml"
    path.write_text(body + '[profile]\nbreakpoints = [[20, 0.01], [2000, 0.01]]\n')
    with pytest.raises(ValueError, match=words) as info:
        read_profile(path)
    assert "bad.toml" in str(info.value)


@pytest.mark.parametrize("spec, words", [
    ("navmat-p9492+sine:120:-0.5", "amplitude must be >= 0 g peak"),
    ("navmat-p9492+sine:0:0.5", "tone frequency must be a finite number > 0"),
    ("navmat-p9492+sine:-50:0.5", "tone frequency must be a finite number > 0"),
    ("navmat-p9492+sine:120", "is not F:PEAK"),
    ("navmat-p9492+sine:120:x", "is not F:PEAK numbers"),
    ("navmat-p9492+sine:", "give F:PEAK pairs"),
    ("+sine:120:0.5", "give a random profile before"),
    ("no-such-env+sine:120:0.5", "unknown profile 'no-such-env'"),
    ("navmat-p9492+sine:120:0.5,120:0.1", "distinct"),
])
def test_parse_rejects_bad_tones_with_one_clear_error(spec, words):
    with pytest.raises(ValueError, match=words) as info:
        parse_profile(spec)
    assert "\n" not in str(info.value)


def test_type_checks():
    flat = RandomProfile.flat(50, 2000)
    with pytest.raises(ValueError, match="at least one tone"):
        SineOnRandom(flat, ())
    with pytest.raises(ValueError, match="RandomProfile"):
        SineOnRandom("flat:50-2000", (Tone(100, 1),))  # type: ignore[arg-type]


# --- vrelab profile -----------------------------------------------------------------------------


def test_cli_profile_grms_includes_the_tones(capsys):
    assert main(["profile", NAVMAT_TONES, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["grms"] == pytest.approx(parse_profile(NAVMAT_TONES).grms, rel=1e-15)
    assert d["random_grms"] == pytest.approx(6.0582, abs=1e-4) and len(d["tones"]) == 2
    assert main(["profile", NAVMAT_TONES, "--grms", "3", "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["grms"] == pytest.approx(3.0, rel=1e-12)
    assert s["tones"][0]["peak_g"] == pytest.approx(0.5 * 3 / d["grms"], rel=1e-12)


def test_cli_profile_text_lists_tones(capsys):
    assert main(["profile", NAVMAT_TONES]) == 0
    out = capsys.readouterr().out
    assert "tone_hz" in out and "0.353553" in out and "random part: 6.05818 g rms" in out


@pytest.mark.parametrize("spec, words", [
    ("navmat-p9492+sine:120:-0.5", "amplitude must be >= 0"),
    ("navmat-p9492+sine:120;0.5", "is not F:PEAK"),
    ("nope+sine:120:0.5", "unknown profile 'nope'"),
])
def test_cli_bad_tones_exit_2_one_line(capsys, spec, words):
    assert main(["profile", spec]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1
