"""Things shared by two rooms live below both: the schedule's trials below the session and the
trial log, the paper's screen numbers with the paper's other numbers in ``stimuli.jung2015``."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _imported_modules(path: Path) -> set[str]:
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
    return found


def test_trials_module_imports_nothing_of_experiment() -> None:
    """``experiment.trials`` is plain data: the log and the session both import it, it neither."""
    imported = _imported_modules(ROOT / "experiment" / "trials.py")
    assert not {m for m in imported if m.split(".")[0] in {"experiment", "stimuli", "analysis"}}


def test_trial_log_does_not_import_the_session_room() -> None:
    """The trial log reads and writes schedules without importing ``experiment.session``."""
    for path in sorted((ROOT / "experiment" / "log").glob("*.py")):
        bad = {m for m in _imported_modules(path) if m.startswith("experiment.session")}
        assert not bad, f"{path.name} imports {bad}"


def test_schedule_names_are_the_trials_module_classes() -> None:
    """The old import place still gives the same classes (one class, two import paths)."""
    from experiment import trials
    from experiment.session import schedule

    assert schedule.Trial is trials.Trial and schedule.Schedule is trials.Schedule
    t = trials.Trial(0, "main", 1, "o1", "cup", "cluttered", 1, 40, 96, "a.png", "0" * 64, 2.0)
    assert trials.Trial.from_dict(t.to_dict()) == t
    assert list(trials.Schedule([t]).iter_trials()) == [t]


def test_paper_screen_numbers_are_the_papers() -> None:
    """Jung et al. 2015, Sec. 3.1: a 1280x1024 CRT at 80 cm, image 14.6 x 9.7 cm, blue border."""
    from stimuli import jung2015

    assert jung2015.SCREEN_SHAPE_PX == (1024, 1280)
    assert jung2015.VIEWING_DISTANCE_CM == 80.0
    assert jung2015.IMAGE_SIZE_CM == (9.7, 14.6)
    assert jung2015.BORDER_RGB == (0, 0, 255)
    # ours: the width at which the 492 px working image is exactly 14.6 cm wide
    px_per_cm = jung2015.WORKING_SHAPE_PX[1] / jung2015.IMAGE_SIZE_CM[1]
    assert abs(jung2015.SCREEN_SHAPE_PX[1] / px_per_cm - jung2015.SCREEN_WIDTH_CM) < 1e-9


def test_display_and_presenter_defaults_come_from_the_paper_module() -> None:
    """The protocol's display and the presenter take their defaults from ``stimuli.jung2015``."""
    from experiment.presentation import geometry
    from experiment.protocol.display import DisplaySpec
    from stimuli import jung2015

    spec = DisplaySpec()
    assert (spec.screen_height_px, spec.screen_width_px) == jung2015.SCREEN_SHAPE_PX
    assert spec.viewing_distance_cm == jung2015.VIEWING_DISTANCE_CM
    assert (spec.image_height_cm, spec.image_width_cm) == jung2015.IMAGE_SIZE_CM
    assert tuple(spec.border_rgb) == jung2015.BORDER_RGB
    assert geometry.PAPER_SCREEN_SHAPE_PX == jung2015.SCREEN_SHAPE_PX
    assert geometry.PAPER_SCREEN_WIDTH_CM == jung2015.SCREEN_WIDTH_CM
    imported = _imported_modules(ROOT / "experiment" / "protocol" / "display.py")
    assert not {m for m in imported if m.startswith("experiment.presentation")}
