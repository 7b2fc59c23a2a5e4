"""IEEE 1293's cross terms have one owner (issue 31): the table of
:mod:`vrelab.models.cross_terms`. The terms identification fits, the terms the triaxial chain
applies (and the triaxial prediction, which reads the chain's list) and the keys a sensor file
accepts all come from it, in their own orders (identify's JSON and covariance: Kip, Kpp, Kio,
Koo, plane by plane; the chain's: the model equation's Kip, Kio, Kpp, Koo, Kpo)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from vrelab.campaigns import MOUNT_PLANES
from vrelab.identification import CROSS, CrossCoupling
from vrelab.models.cross_terms import CROSS_TERMS, FITTED, by_key
from vrelab.sensor import load_sensor
from vrelab.sensor.fields import FIELDS
from vrelab.sensor.parameters import PARAMETERS, identifiable
from vrelab.triaxial.chain import CROSS_TERMS as CHAIN_TERMS
from vrelab.triaxial.chain import TriaxialPolynomial

# IEEE Std 1293-1998's model equation, written out here: each cross-coupling coefficient and
# the two triad axes (i input, p pendulous, o output) whose accelerations it multiplies.
IEEE_1293 = {"Kip": "ip", "Kio": "io", "Kpp": "pp", "Koo": "oo", "Kpo": "po"}


def test_identify_fits_the_chain_applies_and_the_sensor_file_accepts_the_tables_terms() -> None:
    table = {t.key for t in CROSS_TERMS}
    assert {t.label for t in CROSS_TERMS} == set(IEEE_1293)
    # identification: the table's fitted rows, plane by plane in the campaign's mount planes
    assert CROSS == tuple(t.key for t in FITTED) == ("kip_ug_per_g2", "kpp_ug_per_g2", "kio_ug_per_g2", "koo_ug_per_g2")
    assert {t.plane for t in FITTED} == set(MOUNT_PLANES)
    assert set(CROSS) == {n for n in PARAMETERS if n in table}  # what identify writes, and no other cross term
    # the chain (and the triaxial prediction behind it): every row, the Sensor attribute and its two triad positions
    assert CHAIN_TERMS == tuple((t.attr, t.axes[0], t.axes[1]) for t in CROSS_TERMS)
    # the sensor file: its cross-coupling keys are the table's, in its unit, identifiable, fitted where identify fits
    rows = {f.key: f for f in FIELDS if re.fullmatch(r"k[ipo]{2}_ug_per_g2", f.key)}
    assert set(rows) == table
    for t in CROSS_TERMS:
        f = rows[t.key]
        assert (f.name, f.scale, f.identifiable, f.fitted) == (t.attr, t.scale, True, t.fitted), t.key
    assert set(identifiable()) >= table
    # what is not fitted says why
    assert all((t.why_not_fitted is None) == t.fitted for t in CROSS_TERMS)
    assert "Kpo" in by_key()["kpo_ug_per_g2"].why_not_fitted  # type: ignore[operator]


@pytest.mark.parametrize("label", list(IEEE_1293))
def test_each_term_from_a_sensor_file_key_multiplies_its_ieee_1293_axes(label: str) -> None:
    """A sensor file's K (µg/g²) reaches the chain as K·1e-6 /g on the product IEEE 1293 names:
    the z axis's triad is (i, p, o) = (z, x, y) (pendulous the next axis, x -> y -> z -> x)."""
    key = f"k{label[1:]}_ug_per_g2"
    sensor = load_sensor("ideal", range_g=8, axis="z", overrides={key: 250.0})
    poly = TriaxialPolynomial.from_sensor(sensor)
    part = {"x": np.array([0.3, -1.2]), "y": np.array([-0.7, 0.4]), "z": np.array([1.1, 0.9])}
    b = [part["x"], part["y"], part["z"]]
    axis = {"i": "z", "p": "x", "o": "y"}
    a1, a2 = (axis[c] for c in IEEE_1293[label])
    expected = part["z"] + 250.0e-6 * part[a1] * part[a2]
    # one product and one sum in float64: a few ulp
    np.testing.assert_allclose(poly.output(b), expected, rtol=1e-14, atol=1e-15)


def test_the_cross_coupling_documents_model_is_the_ieee_1293_equation() -> None:
    """The JSON's model text, derived from the table, is the equation of fit_cross_coupling's docstring."""
    model = CrossCoupling({}, {}, None, ()).to_dict()["model"]
    assert model == "VRE/σ² = (k2 + 3·k3·w·g)·(w·d)² + Kip·d_i·d_p + Kpp·d_p² + Kio·d_i·d_o + Koo·d_o²"
