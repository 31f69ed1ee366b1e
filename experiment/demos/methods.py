"""``confocal demo --protocol methods_comparison``: the demo's study with k image conditions.

The demo's stimulus set holds the conditions the protocol's blocks name (beyond the photos),
built by :mod:`stimuli.methods` through the same crop, levels and compression; the calibrated
observer sees each condition's images through the session engine, and the analysis is the
k-condition one (:mod:`analysis.conditions`). These helpers keep :mod:`experiment.demos.study`
the paper's demo.
"""

from __future__ import annotations

from typing import Any

__all__ = ["protocol_conditions", "methods_summary_lines"]

#: Conditions of a protocol that are photos, not built by a de-clutter method.
_PHOTO_CONDITIONS = ("photo", "colour_wide", "colour_confocal")


def protocol_conditions(protocol: Any) -> tuple[str, ...] | None:
    """Return the image conditions a protocol's blocks name, for the stimulus build.

    Parameters
    ----------
    protocol : ProtocolSpec

    Returns
    -------
    tuple of str or None
        The conditions in order of first mention (photos left out), or None when they are the
        paper's two (the default build).
    """
    names: list[str] = []
    for block in protocol.blocks:
        for c in block.conditions:
            if c not in _PHOTO_CONDITIONS and c not in names:
                names.append(c)
    if set(names) <= {"cluttered", "decluttered"}:
        return None
    return tuple(names)


def methods_summary_lines(results: dict[str, Any]) -> list[str]:
    """Return the console lines of a method comparison.

    The lines give each condition's threshold and every pair's threshold ratio and Holm-adjusted
    p (computed, never asserted).
    """
    if "comparisons" not in results:
        return []
    lines = [f"conditions: {', '.join(results['conditions'])} (reference {results['reference']})"]
    for c in results["conditions"]:
        t = results["thresholds"].get(c) or {}
        p50 = t.get("p50_pixels")
        lines.append(
            f"50% threshold, {c:<11}: "
            + ("n/a" if p50 is None else f"{p50:,.0f} px")
            + f" ({t.get('status', 'not fitted')})"
        )
    for comp in results["comparisons"]:
        a, b = comp["pair"]
        ratio, p = comp["ratio"], comp["p_adjusted"]
        lines.append(
            f"{a} / {b}: threshold ratio "
            + ("n/a" if ratio is None else f"{ratio:.2f}")
            + ", Holm-adjusted p "
            + ("n/a" if p is None else f"{p:.3g}")
        )
    return lines
