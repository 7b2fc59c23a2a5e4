"""Resource budgets: what an input may ask of the machine, checked before anything is allocated.

Every allocation and run time sized from input (a rate, a duration, a level count, a grid) goes
through one of these checks first, so a slip (``--seconds 1e9``, a corrupt header claiming
4.29 GHz) is refused in milliseconds with what it would have needed, instead of running for
hours or asking for tens of GB.

The budgets are stated here, once, and a user with a bigger machine or more patience raises them
through the environment:

* ``VRELAB_MEMORY_BUDGET_GB`` (default 4): memory one array or one run's bookkeeping may take.
  The machines vrelab is tested on have 24 GiB; 4 GB leaves room for the libraries and a
  second job.
* ``VRELAB_TIME_BUDGET_H`` (default 12): estimated compute time of one simulation, or of one
  analytic prediction (its levels times their propagation).
"""

from __future__ import annotations

import math
import os

# Measured cost of the simulated test per internal sample (sensor chain, drive synthesis and
# the reduction of the record), ADXL355 ±2 g preset, 16 kHz internal rate, 2 cores:
# `vrelab simulate --sensor adxl355 --profile flat:50-2000 --levels 1 --seconds 200` takes
# 0.9 s beyond start-up for 3.4 M internal samples, i.e. 0.27 µs. The estimate takes 0.5 µs
# so that a slower machine is not promised a time it cannot keep.
SIMULATION_SECONDS_PER_SAMPLE = 0.5e-6


# Measured cost of one analytic prediction of one level (vrelab.prediction.predict), the ADXL355
# ±2 g Z preset (resonance, polynomial, over-range, filters, output rails: the costliest closed
# forms), flat 50-2000 Hz, 200 levels, CPU time: 1.8 ms a random level, 0.4 ms a sine level
# (2 cores under load; `bench/bench_predict.py` times the workloads). The estimate takes 5 ms so
# that a slower machine is not promised a time it cannot keep. Each parameter uncertainty the
# sensor carries costs four more predictions (GUM 5.1.2's central differences and the ±u check).
PREDICTION_SECONDS_PER_LEVEL = 5e-3


def _env_float(name: str, default: float) -> float:
    raw = os.environ.get(name)
    if raw is None or raw.strip() == "":
        return default
    try:
        value = float(raw)
    except ValueError:
        raise ValueError(f"{name} must be a number, got {raw!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {raw!r}")
    return value


def memory_budget_bytes() -> float:
    """Memory one run may size from its input [bytes] (``VRELAB_MEMORY_BUDGET_GB``, default 4)."""
    return _env_float("VRELAB_MEMORY_BUDGET_GB", 4.0) * 1e9


def time_budget_s() -> float:
    """Estimated compute time one simulation may take [s] (``VRELAB_TIME_BUDGET_H``, default 12)."""
    return _env_float("VRELAB_TIME_BUDGET_H", 12.0) * 3600.0


def human_bytes(n: float) -> str:
    """``1.2 GB``, ``340 MB``, ``12 kB`` (decimal units, as the budget is stated)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def human_seconds(s: float) -> str:
    """``3.2 days``, ``5.1 h``, ``12 min``, ``40 s``."""
    for unit, scale in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s:.3g} s"


def check_memory(what: str, n_bytes: float) -> None:
    """Refuse ``what`` when it would take more than the memory budget."""
    budget = memory_budget_bytes()
    if not math.isfinite(n_bytes) or n_bytes > budget:
        raise ValueError(
            f"{what} would need {human_bytes(n_bytes) if math.isfinite(n_bytes) else 'unbounded memory'}, "
            f"beyond the {human_bytes(budget)} budget (VRELAB_MEMORY_BUDGET_GB raises it)"
        )


def check_simulation(what: str, n_internal_samples: float, n_bytes: float = 0.0) -> None:
    """Refuse a simulation whose estimated compute time or memory is beyond its budget."""
    _check_time(what, n_internal_samples * SIMULATION_SECONDS_PER_SAMPLE,
                f"{n_internal_samples:.3g} samples at the internal rate"
                + (f", {human_bytes(n_bytes)} of memory" if n_bytes else ""))
    check_memory(what, n_bytes)


def check_prediction(what: str, n_level_evaluations: float) -> None:
    """Refuse an analytic prediction whose estimated compute time is beyond the time budget
    (the one a simulation has, ``VRELAB_TIME_BUDGET_H``): ``n_level_evaluations`` closed-form
    levels at ``PREDICTION_SECONDS_PER_LEVEL`` each."""
    _check_time(what, n_level_evaluations * PREDICTION_SECONDS_PER_LEVEL,
                f"{n_level_evaluations:.3g} level evaluations")


def _check_time(what: str, seconds: float, detail: str) -> None:
    """The time budget's refusal (simulation and prediction): ``what`` would take ``seconds``,
    estimated from ``detail``."""
    budget = time_budget_s()
    if not math.isfinite(seconds) or seconds > budget:
        raise ValueError(
            f"{what} would take about {human_seconds(seconds) if math.isfinite(seconds) else 'forever'} "
            f"({detail}), beyond the {human_seconds(budget)} budget (VRELAB_TIME_BUDGET_H raises it)"
        )
