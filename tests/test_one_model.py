"""One model per concept: one logistic observer, one object record, shared by the towers that
use them (a second class of the same name would drift from the first)."""

from __future__ import annotations

import ast
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent


def _classes_named(name: str) -> list[str]:
    found = []
    for pkg in ("stimuli", "experiment", "analysis"):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            found += [
                f"{path.relative_to(ROOT)}:{n.lineno}"
                for n in ast.walk(tree)
                if isinstance(n, ast.ClassDef) and n.name == name
            ]
    return found


@pytest.mark.parametrize("name", ["LogisticObserver", "ObjectInfo"])
def test_one_class_per_concept(name: str) -> None:
    """Each of these names is defined once in the three packages."""
    assert len(_classes_named(name)) == 1, _classes_named(name)


def test_session_logistic_observer_answers_with_the_model_probability() -> None:
    """The session's ``logistic`` observer gives the closed form of the paper's model:
    logit P = b0 + ln(OR_px) log10(px) + ln(OR_bg) [decluttered] + u + v, P scaled by 1 - lapse,
    with b0 = -ln(OR_px) log10(x50)."""
    from experiment.observers import LogisticParams, LogisticResponder

    objects = {"o1": SimpleNamespace(name="mug"), "o2": SimpleNamespace(name="cup")}
    params = LogisticParams(lapse=0.04, subject_sd=0.3, object_sd=1.0, population_seed=7)
    obs = LogisticResponder(SimpleNamespace(objects=objects), "S1", rng=0, params=params)
    b0 = -math.log(params.or_per_log10_px) * math.log10(params.x50_cluttered_px)
    for condition in ("cluttered", "decluttered"):
        for px in (96.0, 8695.0, 160884.0):
            trial = SimpleNamespace(condition=condition, pixels=px, object="o2")
            eta = (
                b0
                + math.log(params.or_per_log10_px) * math.log10(px)
                + (math.log(params.or_background) if condition == "decluttered" else 0.0)
                + obs.subject_effect
                + obs.object_effects["o2"]
            )
            expected = (1 - params.lapse) / (1 + math.exp(-eta))
            assert obs.p_recognized(trial) == pytest.approx(expected, rel=1e-12)
    photo = SimpleNamespace(condition="photo", pixels=96.0, object="o1")
    assert obs.p_recognized(photo) == pytest.approx(1 - params.lapse)
    # the log's one-line description of the model is still a string (it goes into JSON)
    assert isinstance(obs.model, str) and "logistic" in obs.model


def test_logistic_model_x50_and_odds_ratios() -> None:
    """``from_x50`` puts P = (1 - lapse) / 2 at the cluttered x50; the odds ratios are the
    model's (a factor 10 in pixels multiplies the odds by OR_px, de-cluttering by OR_bg)."""
    from analysis.simulate import LogisticObserver

    obs = LogisticObserver.from_x50(8695.0)
    assert float(obs.p_recognized(8695.0, False)) == pytest.approx(0.5, abs=1e-12)
    p = obs.p_recognized(np.array([100.0, 1000.0, 1000.0]), np.array([False, False, True]))
    odds = p / (1 - p)
    assert odds[1] / odds[0] == pytest.approx(74.5, rel=1e-9)
    assert odds[2] / odds[1] == pytest.approx(5.6, rel=1e-9)
    assert LogisticObserver.from_x50(8695.0) == LogisticObserver()


def test_object_record_is_the_manifest_one(tmp_path: Path) -> None:
    """The engine reads objects.csv into the builder's record, with the builder's checks, and
    refuses a bad row naming the file."""
    from experiment.session import stimset
    from stimuli import manifest

    assert stimset.ObjectInfo is manifest.ObjectInfo
    with pytest.raises(manifest.InputError, match="role must be one of"):
        manifest.ObjectInfo("o1", role="spare")


def test_scene_objects_get_safe_distinct_ids() -> None:
    """A scene may name its objects freely; their records' ids stay folder-safe and distinct."""
    from experiment.active.session import _scene_object

    assert _scene_object("tree").object == "tree"
    a, b = _scene_object("red car"), _scene_object("red  car")
    assert a.name == "red car" and a.object != b.object
    assert a.object.startswith("scene-")
