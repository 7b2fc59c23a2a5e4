"""The front door (issue 21): ``import vrelab`` exports the public API lazily; ``predict``,
``campaign`` and ``identify`` are plain functions (issue 31), correct in every import order
(each order in a fresh interpreter); ``simulate`` and ``analyze`` are real functions; the
package is typed (py.typed shipped); the README's Python example runs."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import norm

import vrelab

ROOT = Path(__file__).resolve().parents[1]


def _censored_vre(mu: float, sigma: float, low: float, high: float) -> float:
    """SPEC 1.1's censored mean of a clipped normal, written out here from scipy's norm."""
    a, b = (low - mu) / sigma, (high - mu) / sigma
    mean = low * norm.cdf(a) + high * norm.sf(b) + mu * (norm.cdf(b) - norm.cdf(a)) + sigma * (norm.pdf(a) - norm.pdf(b))
    return float(mean - mu)


# The ideal ±2 g sensor (rails at exactly ±2 g, no dynamics) in a 1 g field at 1 g rms: SPEC 1.1
# gives -83 mg censored. Each script prints the VRE it got through the front door.
_CALL = ("s = vrelab.load_sensor('ideal', range_g=2); p = vrelab.parse_profile('flat:50-2000')\n"
         "out.append({}(s, p, [1.0], static_g=1.0).levels[0].vre_g)\n")
ORDERS = {
    "the package's function first, then the module's": (
        "import vrelab\nfrom vrelab import predict\nout = []\n" + _CALL.format("predict")
        + "import vrelab.prediction as m\nassert m.predict is predict and predict is vrelab.predict\n"
        "assert m.LevelPrediction is vrelab.LevelPrediction\n" + _CALL.format("m.predict")),
    "the module first, then the package's function": (
        "from vrelab.prediction import predict as f\nimport vrelab\nout = []\n"
        "assert f is vrelab.predict\n" + _CALL.format("f") + _CALL.format("vrelab.predict")),
    "a module importing it before the user does (identification imports predict)": (
        "import vrelab.identification\nimport vrelab\nout = []\n" + _CALL.format("vrelab.predict")
        + "import vrelab.identification as i\nassert vrelab.identify is i.identify and type(vrelab.identify).__name__ == 'function'\n"
        "import vrelab.campaigns as c\nassert callable(vrelab.campaign) and c.read_manifest\n"
        "assert vrelab.campaign.__module__ == 'vrelab._api'\n"),
}


@pytest.mark.parametrize("order", list(ORDERS))
def test_predict_is_one_function_in_every_import_order(order):
    script = ORDERS[order] + "print(__import__('json').dumps(out))\n"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=os.environ, timeout=120)
    assert done.returncode == 0, done.stderr
    values = json.loads(done.stdout)
    assert values and np.allclose(values, _censored_vre(1.0, 1.0, -2.0, 2.0), rtol=1e-6, atol=0)
    assert abs(values[0] - (-0.083)) < 0.0005  # SPEC 1.1: -83 mg


def test_predict_is_a_plain_function_whose_help_starts_with_its_signature():
    """Issue 31: ``vrelab.predict`` was a module made callable, and ``help()`` showed its 22,000-
    character module docstring with the signature last. Now a function: pydoc's text begins with
    the signature (after pydoc's own header line)."""
    import inspect
    import pydoc

    assert inspect.isfunction(vrelab.predict)
    text = pydoc.plain(pydoc.render_doc(vrelab.predict))
    body = [line for line in text.splitlines()[1:] if line.strip()]
    assert body[0].startswith("predict(sensor"), body[:2]


def test_import_vrelab_imports_nothing_heavy():
    """Lazy: ``import vrelab`` loads no model module, no numpy (the CLI's start-up pays it once)."""
    script = ("import sys, vrelab\nheavy = [m for m in ('numpy', 'scipy', 'vrelab.prediction', 'vrelab.sensor', "
              "'vrelab.campaigns', 'vrelab.identification', 'vrelab.shaker') if m in sys.modules]\nprint(heavy)\n"
              "vrelab.VreResult\nprint('vrelab.results' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=os.environ, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:2] == ["[]", "True"]


def test_the_exports_are_the_modules_objects():
    from vrelab import identify
    from vrelab.identification import identify as identify_function
    from vrelab.profiles import parse_profile
    from vrelab.results import VreResult
    from vrelab.sensor import load_sensor

    assert vrelab.load_sensor is load_sensor and vrelab.parse_profile is parse_profile
    assert vrelab.VreResult is VreResult and identify is identify_function
    assert set(vrelab.__all__) <= set(dir(vrelab))
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        vrelab.nonsense  # noqa: B018


def test_the_triaxial_exports_are_the_modules_objects():
    """``vrelab.predict_triaxial`` and the rest of SPEC 1.6's front door; ``vrelab.triaxial``
    exports each module's public names, the heavy ones on first use."""
    import vrelab.triaxial as tri
    from vrelab.prediction.triaxial import predict_triaxial
    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine
    from vrelab.triaxial.simulate import simulate_triaxial

    assert vrelab.predict_triaxial is predict_triaxial and vrelab.simulate_triaxial is simulate_triaxial
    assert vrelab.TriaxialProfile is TriaxialProfile and vrelab.TriaxialSine is TriaxialSine
    assert tri.predict_triaxial is predict_triaxial and set(tri.__all__) <= set(dir(tri))
    for name in tri.__all__:
        module = getattr(tri, name).__module__ if hasattr(getattr(tri, name), "__module__") else None
        assert module is None or module.startswith(("vrelab.triaxial.", "vrelab.prediction.")), (name, module)
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        tri.nonsense  # noqa: B018
    script = ("import sys, vrelab.triaxial\nprint([m for m in ('scipy', 'vrelab.prediction.triaxial', "
              "'vrelab.triaxial.simulate') if m in sys.modules])")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=os.environ, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


def test_identify_is_a_plain_function_whose_help_starts_with_its_signature():
    """``vrelab.identify`` is :func:`vrelab.identification.identify` itself (issue 31: no module made
    callable), so ``help()`` shows its signature first, then its own docstring, not a module's."""
    import inspect
    import pydoc

    import vrelab.identification

    assert inspect.isfunction(vrelab.identify) and vrelab.identify is vrelab.identification.identify
    text = pydoc.render_doc(vrelab.identify, renderer=pydoc.plaintext)
    first = [line for line in text.splitlines() if line.strip()][1]  # after pydoc's "Python Library Documentation" line
    assert first.startswith("identify(doc"), first
    assert "Identify every channel of a campaign" in text and len(text) < 5000


def test_simulate_sine_gives_the_polynomial_vre():
    """A pure quadratic, no static field, a sine at 1 g rms: VRE = k2·rms² (SPEC 1.2) = 1 mg."""
    sensor = vrelab.load_sensor("ideal", range_g=8, k2_ug_per_g2=1000)
    result = vrelab.simulate(sensor, freq_hz=200, levels=[1.0], static_g=0.0, seconds=2, seed=3)
    assert result.method == "sine" and len(result.levels) == 1
    level = result.levels[0]
    assert abs(level.rms_g - 1.0) < 0.02
    assert abs(level.vre.value - 1e-3 * level.rms_g**2) < max(3 * level.vre.u, 2e-5)


def test_simulate_refuses_an_ambiguous_test():
    sensor = vrelab.load_sensor("ideal", range_g=2)
    with pytest.raises(ValueError, match="either profile .* or freq_hz"):
        vrelab.simulate(sensor, "flat:50-2000", [1.0], freq_hz=100)
    with pytest.raises(ValueError, match="either profile .* or freq_hz"):
        vrelab.simulate(sensor, levels=[1.0])
    with pytest.raises(ValueError, match="levels is empty"):
        vrelab.simulate(sensor, "flat:50-2000", [])


def test_analyze_of_a_simulated_record_gives_what_the_simulation_reduced(tmp_path):
    """The random method through the front door twice: simulate writes its record, analyze
    reads it back from the file with its default options (the simulation's reduction sets its
    band from the profile's breakpoints, so the rms differ by a fraction of a per cent)."""
    from vrelab.analysis import FitOptions, ReductionOptions

    sensor = vrelab.load_sensor("ideal", range_g=2)
    record = tmp_path / "record.h5"
    simulated = vrelab.simulate(sensor, "flat:50-2000", [1.0, 1.5], static_g=1.0, seconds=2, seed=5,
                                record_path=record)
    measured = vrelab.analyze(record, dut="dut", reference="reference",
                              options=ReductionOptions(profile=vrelab.parse_profile("flat:50-2000")),
                              fit=FitOptions(static_g=1.0))
    assert len(measured.levels) == len(simulated.levels) == 2
    for m, s in zip(measured.levels, simulated.levels):
        assert abs(m.rms_g / s.rms_g - 1) < 0.005
        assert abs(m.vre.value - s.vre.value) < 3 * max(m.vre.u, s.vre.u)
        # and both near SPEC 1.1's censored shift at the measured rms
        assert abs(m.vre.value - _censored_vre(1.0, m.rms_g, -2.0, 2.0)) < 4 * m.vre.u + 2e-3


def test_campaign_gives_the_document_the_cli_prints(tmp_path, capsys):
    """One run of the shipped example campaign, through vrelab.campaign and `vrelab campaign --json`."""
    from vrelab.cli import main

    text = (ROOT / "examples" / "campaign" / "campaign.toml").read_text()
    head, first = text.split("[[run]]")[:2]
    manifest = tmp_path / "one.toml"
    manifest.write_text(head.replace("# A simulated", "# One run of a simulated") + "[[run]]" + first)
    (tmp_path / "runs").symlink_to(ROOT / "examples" / "campaign" / "runs")
    doc = vrelab.campaign(manifest)
    assert main(["campaign", str(manifest), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert doc["n_runs"] == 1 and [c["channel"] for c in doc["channels"]] == ["sn1", "sn2"]
    assert json.loads(json.dumps(doc["channels"])) == printed["channels"]
    assert json.loads(json.dumps(doc["runs"])) == printed["runs"]


def test_the_package_is_typed():
    assert (ROOT / "src" / "vrelab" / "py.typed").is_file()
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "py.typed" in package_data["vrelab"]


def test_the_readme_python_example_runs(tmp_path, monkeypatch, capsys):
    """Every ```python block of README.md, in order, in one namespace (a user pasting them)."""
    blocks = re.findall(r"^```python\n(.*?)^```", (ROOT / "README.md").read_text(), flags=re.S | re.M)
    assert blocks, "README.md has no ```python block"
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__readme__"}
    for block in blocks:
        exec(compile(block, "README.md", "exec"), namespace)
    assert "VRE" in capsys.readouterr().out


def test_analyze_takes_the_clis_names_for_units_and_sensitivity(capsys):
    """``vrelab.analyze(..., dut_units="lsb", dut_sensitivity=256000, ...)`` reduces the example
    run as ``vrelab analyze --dut-units lsb --dut-sensitivity 256000 ...`` does (the same
    numbers: one reduction behind both); a pair beside a Scale is refused, an unknown keyword a
    TypeError, a bad unit the CLI's words."""
    from vrelab.cli import main

    run = ROOT / "examples" / "campaign" / "runs" / "03_z_up_300hz.uff"
    assert main(["analyze", str(run), "--dut", "101:+Z", "--reference", "1:+Z", "--reference-units", "mv",
                 "--reference-sensitivity", "10", "--dut-units", "lsb", "--dut-sensitivity", "256000", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    res = vrelab.analyze(str(run), dut="101:+Z", reference="1:+Z", reference_units="mv", reference_sensitivity=10,
                         dut_units="lsb", dut_sensitivity=256000)
    assert [lv.vre.value for lv in res.levels] == [lv["vre_g"] for lv in cli["levels"]]
    assert [lv.rms_g for lv in res.levels] == [lv["rms_g"] for lv in cli["levels"]]
    # U and k as the CLI prints them (its default budget: the record's own u), U = k·u (GUM 6.2.1)
    assert [(lv.U_vre_g, lv.k) for lv in res.levels] == [(lv["U_vre_g"], lv["k"]) for lv in cli["levels"]]
    assert all(lv.U_vre_g == lv.k * lv.vre.u for lv in res.levels)  # type: ignore[operator]
    from vrelab.analysis.readers import Scale

    with pytest.raises(ValueError, match="give dut_scale or dut_units/dut_sensitivity, not both"):
        vrelab.analyze(str(run), dut="101:+Z", reference="1:+Z", dut_scale=Scale("lsb", 256000), dut_units="lsb",
                       dut_sensitivity=256000)
    with pytest.raises(ValueError, match="dut units 'lsb' need a sensitivity"):
        vrelab.analyze(str(run), dut="101:+Z", reference="1:+Z", dut_units="lsb")
    with pytest.raises(TypeError, match="dut_unit"):
        vrelab.analyze(str(run), dut="101:+Z", reference="1:+Z", dut_unit="lsb")
