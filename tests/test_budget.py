"""Resource budgets: refusals name what was asked and the budget; the environment raises it."""

from __future__ import annotations

import pytest

from vrelab import _budget as B


def test_memory_refusal_names_need_and_budget(monkeypatch):
    monkeypatch.delenv("VRELAB_MEMORY_BUDGET_GB", raising=False)
    B.check_memory("a 1 GB array", 1e9)
    with pytest.raises(ValueError, match=r"window table would need 74.5 GB, beyond the 4 GB budget"):
        B.check_memory("window table", 74.5e9)
    monkeypatch.setenv("VRELAB_MEMORY_BUDGET_GB", "100")
    B.check_memory("window table", 74.5e9)
    monkeypatch.setenv("VRELAB_MEMORY_BUDGET_GB", "-1")
    with pytest.raises(ValueError, match="VRELAB_MEMORY_BUDGET_GB must be a finite number > 0"):
        B.check_memory("x", 1.0)


def test_simulation_refusal_states_the_time(monkeypatch):
    """1e9 s at 16 kHz is 1.6e13 samples: at 0.5 µs each, about 93 days."""
    monkeypatch.delenv("VRELAB_TIME_BUDGET_H", raising=False)
    n = 1e9 * 16000.0
    with pytest.raises(ValueError, match=r"would take about 92.6 days \(1.6e\+13 samples.*beyond the 12 h budget"):
        B.check_simulation("simulate: 1 level of 1e9 s", n)
    B.check_simulation("an hour at 16 kHz", 3600 * 16000.0)
    with pytest.raises(ValueError, match="forever"):
        B.check_simulation("x", float("inf"))


def test_human_units():
    assert B.human_bytes(74.5e9) == "74.5 GB" and B.human_bytes(512) == "512 B"
    assert B.human_seconds(90) == "1.5 min" and B.human_seconds(5) == "5 s"
