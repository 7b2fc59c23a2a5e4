"""Identification: the sensor's VRE model from a campaign, per channel (physics §6.1).

A campaign measures a part under a few conditions (orientations, sine frequencies, random
levels); a designer needs its VRE under *their* vibration, range and bandwidth. This package
fits the physical model of physics §1 to every level of every run of a channel at once — one
weighted least-squares likelihood, each level weighted by its Type A standard uncertainty —
and writes the result as a sensor file that ``predict``, ``simulate`` and ``sweep`` take.

The model of a level is :func:`vrelab.prediction.predict` on the base sensor with the parameters
set (:func:`vrelab.sensor.parameters.with_parameters`): the same analytic model, walked through
the same stages, that ``vrelab predict`` evaluates, so identification and prediction cannot
drift apart. The parameters (:data:`vrelab.sensor.parameters.PARAMETERS`):

* ``k2_ug_per_g2``, ``k3_ug_per_g3`` — from the sine runs' orientations: a sine at f in a field
  g0 gives ``VRE = (k2 + 3·k3·g0)·|H(f)|²·rms²`` (physics §1.2, §1.3); two static fields separate
  them (random levels carry k·σ² under the clipping's share, which the rails also shape). A
  level whose drive was measured distorted (the document's ``drive``, physics §4.4) gives
  ``k2·E[x²] + k3·(3·g0·E[x²] + E[x³])``, modelled as the pure sine of its E[x²] at
  g0 + E[x³]/(3·E[x²]) (:func:`drive_equivalent`);
* ``fn_hz``, ``q`` — from VRC(f) across the sine frequencies, ``|H(f)|² = 1/((1-r²)² + (r/Q)²)``;
* ``rail_low_g``, ``rail_high_g`` — from the random runs, through the identified dynamics and
  the base sensor's filters (the physical rail where the clip sits, not the effective rail that
  a fit against the reference's rms gives);
* ``overrange_threshold_g`` — from the random runs, where the data reach it (the base sensor
  must give the hold time);
* ``kip_ug_per_g2``, ``kpp_ug_per_g2``, ``kio_ug_per_g2``, ``koo_ug_per_g2`` — IEEE 1293's
  cross-coupling coefficients (physics §1.6), from the sine runs mounted at an angle (the manifest's
  ``mount_deg``, ``mount_plane``), by their own linear fit on the model identified from the
  others (:func:`fit_cross_coupling`); those runs stay out of the fit above.

What the campaign cannot determine is null with its reason: k2 and k3 without a sine run; k3
with one orientation; k2 too when that orientation is not 0 g (then only ``k2 + 3·k3·g0`` is
known, and said); fn and Q with fewer than three sine frequencies (two fix k and one combination
of fn and Q); a rail or the over-range threshold whose share of the VRE stays within 3 standard
uncertainties over the levels (fixed at the base sensor's value, the rest refitted). The sensor
file takes those from the base sensor as assumptions, with the u the base states for them (its
``[uncertainty]`` table: a datasheet tolerance, a filter corner) or said to have none.

fn and Q are judged by their profile likelihood on the sine runs' apparent VRCs
(:mod:`vrelab.identification.model`), not by the fit's local curvature alone: where every sine frequency
lies on one flank of the fitted fn (or below ``NEAR_FN``·fn), or a parameter's ±1σ profile
interval does not close (a Q the runs bound from below only), the parameter is null with the
bound the data give in its reason ("Q > 4.2"), stays free in the fit as a nuisance parameter
(k2 and k3 must not absorb a resonance the runs show), and goes into the sensor file as an
assumption whose u spans that bound, so ``predict`` says where its u is no claim. Where the
interval closes, fn and Q are kept with their value, u and correlations however large the u
(``prefer_base`` takes the base's instead), the u widened where the profile is wider than its
own curvature says. Levels the analytic sum does not cover (a sine peak at a rail, judged with
the identified rails; a random level where clipping and the nonlinearity interact beyond half
its u) are left out with a note; the choice is iterated with the fit.

Uncertainty: the covariance ``(JᵀJ)⁻¹`` of the whitened residuals at the solution (J by
central differences), scaled by the reduced χ² when that exceeds 1 (the Birge ratio, as the
campaign's combinations do). Declared Type B terms (physics §4.3: reference and DUT sensitivity,
static field, thermal offset) enter by refitting with each input perturbed by its standard
uncertainty (:func:`vrelab.gum.type_b_shifts`); each gives a shift vector ``d`` and the
covariance gains ``d·dᵀ`` (the shifts are fully correlated across parameters).

Data flow: campaign document (``vrelab campaign``'s results.json, or a manifest reduced here)
-> :func:`observations` -> :func:`identify_channel` per channel -> :class:`Identification`
-> :func:`write_sensor_file` (DIR/sensor.toml) and the JSON document.

Modules, in the order the data flow through them: :mod:`~vrelab.identification.observation`
(the campaign document's runs as :class:`Observation`), :mod:`~vrelab.identification.model`
(a level's model and what the campaign can determine), :mod:`~vrelab.identification.fitting`
(the least squares), :mod:`~vrelab.identification.channel` (:func:`identify_channel`),
:mod:`~vrelab.identification.check2f`, :mod:`~vrelab.identification.cross_coupling`,
:mod:`~vrelab.identification.api` (:func:`identify`) and
:mod:`~vrelab.identification.sensor_file`.
"""

from vrelab.identification.api import Identification, identify
from vrelab.identification.channel import IdentifyOptions, identify_channel
from vrelab.identification.check2f import cross_check_2f
from vrelab.identification.cross_coupling import CROSS, CrossCoupling, fit_cross_coupling
from vrelab.identification.model import NEAR_FN, REACH_SIGMA, model_levels
from vrelab.identification.observation import ChannelModel, Observation, apparent_vrc, observations
from vrelab.identification.sensor_file import sensor_file_document, write_sensor_file

__all__ = ["Observation", "ChannelModel", "Identification", "IdentifyOptions", "observations", "identify",
           "identify_channel",
           "CrossCoupling", "fit_cross_coupling", "CROSS",
           "model_levels", "apparent_vrc", "cross_check_2f", "sensor_file_document", "write_sensor_file", "REACH_SIGMA", "NEAR_FN"]
