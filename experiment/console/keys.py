"""The operator's score keys, shared by every console that scores an answer."""

from __future__ import annotations

from textual.binding import Binding

__all__ = ["SCORE_KEYS", "score_bindings"]

#: Function keys of the five scores (Jung et al. 2015, Sec. 3.2: name, use, shape/features, pass;
#: "wrong" is the engine's score for a wrong name).
SCORE_KEYS: dict[str, str] = {
    "f1": "named",
    "f2": "use",
    "f3": "shape",
    "f4": "wrong",
    "f5": "pass",
}


def score_bindings() -> list[Binding]:
    """Return the Textual bindings of :data:`SCORE_KEYS`: each key runs ``action_score(score)``.

    Priority bindings, so that they work while the response line has the focus.
    """
    return [Binding(k, f"score('{s}')", s, priority=True) for k, s in SCORE_KEYS.items()]
