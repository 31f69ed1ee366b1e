"""The shipped method-comparison protocol and ``confocal demo --protocol methods_comparison``."""

from __future__ import annotations

import json

import pytest

from experiment.demos.methods import methods_summary_lines, protocol_conditions
from experiment.protocol import load_protocol

FIVE = ("cluttered", "decluttered", "mask", "segment", "saliency")


def test_shipped_protocol_counterbalances_five_conditions():
    spec = load_protocol("methods_comparison")
    main = [b for b in spec.blocks if b.part == "main"]
    assert len(main) == 1 and main[0].conditions == FIVE
    assert main[0].condition_order == "latin_square" and main[0].levels == tuple(range(1, 9))
    assert protocol_conditions(spec) == FIVE
    assert protocol_conditions(load_protocol("jung2015")) is None


def test_summary_lines_name_every_pair():
    results = {
        "conditions": ["cluttered", "mask"],
        "reference": "cluttered",
        "thresholds": {"cluttered": {"p50_pixels": 8000.0, "status": "measured"}, "mask": {}},
        "comparisons": [{"pair": ["cluttered", "mask"], "ratio": None, "p_adjusted": 0.01}],
    }
    lines = methods_summary_lines(results)
    assert "8,000 px" in lines[1] and "n/a (not fitted)" in lines[2]
    assert lines[3] == "cluttered / mask: threshold ratio n/a, Holm-adjusted p 0.01"
    assert methods_summary_lines({"thresholds": {}}) == []


@pytest.mark.slow
def test_methods_demo_end_to_end(tmp_path):
    """One simulated subject (the paper's logistic observer, for speed) through the whole
    comparison: a five-condition set, a counterbalanced session, the k-condition report."""
    from experiment.demos.study import run_demo

    demo = run_demo(
        tmp_path / "d",
        n_subjects=1,
        observer="logistic",
        protocol="methods_comparison",
        show_progress=False,
    )
    r = demo.results
    assert r["conditions"] == list(FIVE)
    assert set(r["thresholds"]) == set(FIVE)
    assert len(r["comparisons"]) == 10
    assert sorted(r["logistic"]["odds_ratios"]) == sorted(FIVE[1:])
    meta = json.loads((tmp_path / "d" / "stimuli" / "stimulus_set.json").read_text())
    assert list(meta["conditions"]) == list(FIVE)
    assert "Simulated observers" in (tmp_path / "d" / "report" / "report.md").read_text()
