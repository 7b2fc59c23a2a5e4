"""IEEE 1293's mount-angle procedure for the cross-coupling coefficients (issue 22, SPEC 1.6).

The truth is the model equation's closed form (SPEC 1.6, IEEE Std 1293-1998): a sine of rms σ
along ``d = (cos φ, sin φ, 0)`` (IP plane) in the static field g, below the rails, rectifies
``VRE = σ²·[(k2 + 3·k3·g_i)·cos²φ + Kip·sinφ·cosφ + Kpp·sin²φ]`` (k4 = 0, w = (1, 0, 0); the
cubic's ``E[x³] = 0`` for a sine), written here from that equation, not from vrelab. The
levels carry Gaussian noise of a stated u (seeded), so the identified coefficients must
recover the truth within their u, and do so at the normal rate over seeds.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vrelab.campaigns import read_manifest
from vrelab.identification import CROSS, identify

TRUTH = {"k2": 2000.0, "k3": 300.0, "kip_ug_per_g2": 500.0, "kpp_ug_per_g2": -300.0,
         "kio_ug_per_g2": -400.0, "koo_ug_per_g2": 200.0}
LEVELS = (0.2, 0.4, 0.6)
U_G = 2e-6  # each level's standard uncertainty [g]


def _vre(phi_deg: float, plane: str, g_vec: tuple[float, float, float], rms: float, truth: dict[str, float],
         w_p: float = 0.0) -> float:
    """SPEC 1.6's closed form in g for the IP or IO plane (sine, below the rails), with a
    cross-axis sensitivity ``w_p`` toward p: u = (g_i + w_p·g_p) + (cos φ + w_p·sin φ)·x in the IP
    plane, and the cubic's mean shift 3·k3·E[u]·Var-part (E[x³] = 0)."""
    c, s = math.cos(math.radians(phi_deg)), math.sin(math.radians(phi_deg))
    kx, kk = ("kip_ug_per_g2", "kpp_ug_per_g2") if plane == "ip" else ("kio_ug_per_g2", "koo_ug_per_g2")
    wd = c + (w_p * s if plane == "ip" else 0.0)
    gs = g_vec[0] + w_p * g_vec[1]
    per_ms = (truth["k2"] + 3 * truth["k3"] * gs) * wd * wd + truth[kx] * s * c + truth[kk] * s * s
    return per_ms * rms**2 * 1e-6


def _vertical(phi: float, plane: str, up: float = 1.0) -> tuple[float, float, float]:
    """The static field on a vertical shaker: along the vibration's direction."""
    c, s = math.cos(math.radians(phi)), math.sin(math.radians(phi))
    return (up * c, up * s, 0.0) if plane == "ip" else (up * c, 0.0, up * s)


def campaign(mounts: list[tuple[float | None, str, float]], seed: int, truth: dict[str, float] = TRUTH,
             freq_hz: float = 80.0, w_p: float = 0.0) -> dict:
    """A campaign document (the shape vrelab.campaign.campaign_doc writes) of one channel: each
    run (angle or None for an ordinary run, plane, up = ±1) at ``LEVELS``, VRE from the closed
    form plus N(0, U_G)."""
    rng = np.random.default_rng(seed)
    runs = []
    for k, (phi, plane, up) in enumerate(mounts, 1):
        g = _vertical(phi or 0.0, plane, up)
        ch: dict = {"channel": "dut", "static_g": g[0]}
        if phi is not None:
            ch.update(mount_deg=phi, mount_plane=plane, static_vector_g=list(g))
        ch["levels"] = [{"rms_g": r, "vre_g": _vre(phi or 0.0, plane, g, r, truth, w_p) + float(rng.normal(0, U_G)),
                         "u_vre_g": U_G, "freq_hz": freq_hz, "dof": 40.0, "flags": []} for r in LEVELS]
        runs.append({"index": k, "label": f"{plane} {phi}° {up:+g} g", "status": "ok", "method": "sine",
                     "profile": None, "budget": {}, "channels": [ch]})
    return {"kind": "campaign", "name": "mount-angle closed form", "runs": runs}


FULL = [(None, "ip", 1.0), (None, "ip", -1.0), (45.0, "ip", 1.0), (-45.0, "ip", 1.0), (90.0, "ip", 1.0),
        (45.0, "io", 1.0), (-45.0, "io", 1.0), (90.0, "io", 1.0)]


def _ident(doc: dict, base: str = "ideal"):
    return identify(doc, base, range_g=8.0).channels[0]


def test_kip_kpp_kio_koo_recovered_within_u():
    cm = _ident(campaign(FULL, seed=1))
    for n in CROSS:
        e = cm.parameters[n]
        assert e is not None, cm.reasons.get(n)
        assert abs(e.value - TRUTH[n]) <= 3 * e.u, (n, e, TRUTH[n])
        assert 0 < e.u < 50  # µg/g²: the noise of U_G over σ² = 0.04..0.36 g², not a vacuous u
    assert cm.parameters["k2_ug_per_g2"] is not None
    d = cm.to_dict()
    assert set(CROSS) <= set(d["covariance"]["params"])
    assert d["cross_coupling"]["points"]


def test_coverage_over_seeds():
    """The 1-u interval of Kip covers the truth about 68 % of the time (20 seeds: 8..19 within
    1 u is the binomial's 99 % range for p = 0.683)."""
    hits = {n: 0 for n in ("kip_ug_per_g2", "kio_ug_per_g2")}
    for seed in range(20):
        cm = _ident(campaign(FULL, seed=100 + seed))
        for n in hits:
            e = cm.parameters[n]
            hits[n] += abs(e.value - TRUTH[n]) <= e.u
    for n, h in hits.items():
        assert 8 <= h <= 19, (n, h)


def test_without_pm45_pair_kip_is_null_with_reason():
    one_side = [m for m in FULL if m[0] != -45.0]
    cm = _ident(campaign(one_side, seed=2))
    for n in ("kip_ug_per_g2", "kio_ug_per_g2"):
        assert cm.parameters[n] is None
        assert "one way only" in cm.reasons[n] and "±φ pair" in cm.reasons[n]
    assert cm.parameters["kpp_ug_per_g2"] is not None  # the 90° run still gives it


def test_only_90_degrees_leaves_kip_not_excited_and_gives_kpp():
    cm = _ident(campaign([m for m in FULL if m[0] in (None, 90.0)], seed=8))
    assert cm.parameters["kip_ug_per_g2"] is None and "not excited" in cm.reasons["kip_ug_per_g2"]
    kpp = cm.parameters["kpp_ug_per_g2"]
    assert abs(kpp.value - TRUTH["kpp_ug_per_g2"]) <= 3 * kpp.u


def test_pm45_pair_alone_gives_kip_but_not_kpp():
    """0° at +1 g and ±45°: the pair's difference is Kip alone; their sum is
    (k2 + 3·k3·cos φ)/2 + Kpp/2, which one orientation at 0° cannot split (not estimable)."""
    cm = _ident(campaign([(None, "ip", 1.0), (45.0, "ip", 1.0), (-45.0, "ip", 1.0)], seed=9))
    kip = cm.parameters["kip_ug_per_g2"]
    assert abs(kip.value - TRUTH["kip_ug_per_g2"]) <= 3 * kip.u
    assert cm.parameters["kpp_ug_per_g2"] is None and "do not separate Kpp" in cm.reasons["kpp_ug_per_g2"]


def test_one_plane_only_leaves_kio_koo_null():
    ip_only = [m for m in FULL if m[1] == "ip"]
    cm = _ident(campaign(ip_only, seed=3))
    assert cm.parameters["kip_ug_per_g2"] is not None
    for n in ("kio_ug_per_g2", "koo_ug_per_g2"):
        assert cm.parameters[n] is None
        assert "no run mounted in the IO plane" in cm.reasons[n]


def test_no_mount_runs_nulls_every_cross_term():
    cm = _ident(campaign([(None, "ip", 1.0), (None, "ip", -1.0)], seed=4))
    for n in CROSS:
        assert cm.parameters[n] is None and "no run mounted at an angle" in cm.reasons[n]
    assert cm.cross_coupling is None


def test_tilted_runs_stay_out_of_k2_k3():
    """The main model's k2 and k3 come from the runs along the vibration only: adding the tilted
    runs changes them not at all (same seed for the axial runs' noise)."""
    axial = _ident(campaign(FULL[:2], seed=5))
    both = _ident(campaign(FULL, seed=5))
    for n in ("k2_ug_per_g2", "k3_ug_per_g3"):
        assert both.parameters[n].value == pytest.approx(axial.parameters[n].value, rel=1e-9)


def test_apparent_kip_note_when_no_cross_axis_sensitivity():
    cm = _ident(campaign(FULL, seed=6))
    assert any("apparent Kip + 2·k2·w_p" in n for n in cm.notes)


def _base_with_cross_axis(tmp_path: Path, w_p: float) -> str:
    """The ideal preset with a cross-axis sensitivity toward the pendulous axis of its default axis."""
    from vrelab.sensor import load_sensor

    p = "xyz"[load_sensor("ideal").triad[1]]
    src = Path(__file__).resolve().parents[1] / "src/vrelab/sensor/presets/ideal.toml"
    f = tmp_path / "base.toml"
    f.write_text(src.read_text(encoding="utf-8").replace("[facts]", f"cross_axis_{p} = {w_p}\n[facts]", 1),
                 encoding="utf-8")
    return str(f)


def test_cross_axis_feed_is_the_apparent_kip_or_modelled(tmp_path: Path):
    """A part with w_p = 0.02 (k3 = 0: the feed is then exactly 2·k2·w_p·sinφ·cosφ + k2·w_p²·sin²φ):
    on a base without w_p the identified Kip is the apparent Kip + 2·k2·w_p (580 µg/g²) and Kpp
    the apparent Kpp + k2·w_p²; on a base that states w_p they are the part's own."""
    truth = {**TRUTH, "k3": 0.0}
    doc = campaign(FULL, seed=7, truth=truth, w_p=0.02)
    apparent = _ident(doc)
    kip, kpp = apparent.parameters["kip_ug_per_g2"], apparent.parameters["kpp_ug_per_g2"]
    assert abs(kip.value - (500.0 + 2 * 2000.0 * 0.02)) <= 3 * kip.u
    assert abs(kpp.value - (-300.0 + 2000.0 * 0.02**2)) <= 3 * kpp.u
    own = _ident(doc, _base_with_cross_axis(tmp_path, 0.02))
    kip = own.parameters["kip_ug_per_g2"]
    assert abs(kip.value - 500.0) <= 3 * kip.u, kip
    assert any("w_p = 0.02 of the base sensor is modelled" in n for n in own.notes)


# --------------------------------------------------------------------------- the manifest

GOOD = ('[[run]]\nfile = "f.csv"\ndut = "y"\nlabel = "IP +45"\nmount_deg = 45\nmount_plane = "ip"\n'
        'static_g = [0.70710678, 0.70710678, 0]\n')


@pytest.mark.parametrize("edit, words", [
    (("static_g = [0.70710678, 0.70710678, 0]", "static_g = 0.7071"), ["run 1 ('IP +45')", "[i, p, o]", "ambiguous"]),
    (("static_g = [0.70710678, 0.70710678, 0]", "static_g = [1, 0, 0]"), ["run 1", "neither along the vibration"]),
    (("static_g = [0.70710678, 0.70710678, 0]", "static_g = [0.5, 0.5, 0]"), ["run 1", "1 g"]),
    (('mount_plane = "ip"', 'mount_plane = "po"'), ["run 1", "mount_plane must be ip"]),
    (("mount_deg = 45", "mount_deg = nan"), ["run 1", "mount_deg must be a finite number"]),
    (('mount_plane = "ip"\n', ""), ["run 1", "mount_deg without mount_plane"]),
    (("mount_deg = 45\n", ""), ["run 1", "mount_plane without mount_deg"]),
    (("static_g = [0.70710678, 0.70710678, 0]\n", ""), ["run 1", "'static_g' missing", "[i, p, o]"]),
    (("static_g = [0.70710678, 0.70710678, 0]", "static_g = {z = [0.70710678, 0.70710678, 0]}"),
     ["run 1", "'z' is not a DUT channel"]),
    (("static_g = [0.70710678, 0.70710678, 0]", "static_g = [0.7, true, 0]"), ["run 1", "three numbers"]),
])
def test_bad_mount_key_refused_in_one_line(tmp_path: Path, edit, words):
    (tmp_path / "f.csv").write_text("x,y\n0,0\n")
    (tmp_path / "m.toml").write_text(GOOD.replace(*edit))
    with pytest.raises(ValueError) as exc:
        read_manifest(tmp_path / "m.toml", check_files=False)
    msg = str(exc.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg, (w, msg)


def test_mount_manifest_reads_and_slip_table_is_stated(tmp_path: Path):
    (tmp_path / "f.csv").write_text("x,y\n0,0\n")
    (tmp_path / "m.toml").write_text(GOOD + '[[run]]\nfile = "f.csv"\ndut = "y"\nlabel = "slip"\nmount_deg = -45\n'
                                     'mount_plane = "ip"\nstatic_g = [0, 0, 1]\n')
    m = read_manifest(tmp_path / "m.toml", check_files=False)
    a, b = (r.mount["y"] for r in m.runs)
    assert (a.shaker, b.shaker) == ("vertical", "slip table")
    assert m.runs[0].static_g["y"] == pytest.approx(0.70710678) and m.runs[1].static_g["y"] == 0.0


def test_vector_static_without_mount_refused(tmp_path: Path):
    (tmp_path / "f.csv").write_text("x,y\n0,0\n")
    (tmp_path / "m.toml").write_text('[[run]]\nfile = "f.csv"\ndut = "y"\nstatic_g = [1, 0, 0]\n')
    with pytest.raises(ValueError, match="belongs to a mount-angle run"):
        read_manifest(tmp_path / "m.toml", check_files=False)


def test_cli_refuses_bad_mount_in_one_line(tmp_path: Path):
    (tmp_path / "f.csv").write_text("x,y\n0,0\n")
    (tmp_path / "m.toml").write_text(GOOD.replace("mount_deg = 45", 'mount_deg = "45°"'))
    r = subprocess.run([sys.executable, "-m", "vrelab", "campaign", str(tmp_path / "m.toml"), "--json"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "mount_deg" in lines[0] and "run 1" in lines[0], r.stderr


def test_units_check_reads_a_mounted_run_at_its_cos_phi():
    """A DUT mounted at φ sees cos φ of the vibration: the campaign's units check judges its
    DUT/reference ratio divided by |cos φ| (a 9.81 slip at 45° still shows as 9.81), and not at
    all where |cos φ| < 0.5 (a 90° run reads only the cross-axis feed)."""
    from vrelab.analysis.plausibility import check_units_over_runs
    from vrelab.campaigns import Mount
    from vrelab.campaigns.runs import _mount_probes

    at45 = Mount(45.0, "ip", (math.sqrt(0.5), math.sqrt(0.5), 0.0))
    at90 = Mount(90.0, "ip", (0.0, 1.0, 0.0))
    c = math.sqrt(0.5)
    fine = _mount_probes(at45, [("sine", 80.0, c * 1.01)] * 3)
    assert [p[2] for p in fine] == pytest.approx([1.01] * 3)
    assert check_units_over_runs("dut", fine) is None
    assert check_units_over_runs("dut", _mount_probes(at45, [("sine", 80.0, c * 9.81)] * 3)) is not None
    assert _mount_probes(at90, [("sine", 80.0, 0.01)] * 3) == []
    assert _mount_probes(None, [("sine", 80.0, 0.2)]) == [("sine", 80.0, 0.2)]
