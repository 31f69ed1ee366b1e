"""Simulated searchers for the active-search task (labelled simulated wherever they appear).

A searcher sees what the implant shows and decides the next key. :class:`SimulatedSearcher`
scans planes in order (``planes``: jumps between the detected object planes, nearest first;
``ordered``: steps the depth from near to far one key at a time), and stops when its model
observer, :class:`EdgeRecogniser`, recognises the cued object. When the recogniser is unsure
and zoom is allowed, it zooms on the lit cells once before moving on. Its time per key and per
look is drawn from log-normal distributions (ours, not measured on people), so its
time-to-recognition is a simulated number, not a human one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from experiment.active import adapter
from experiment.viewer.reference import Panes
from experiment.viewer.state import ViewerModel, ViewerState

__all__ = [
    "Action",
    "Observation",
    "Searcher",
    "RecogniserParams",
    "EdgeRecogniser",
    "SimulatedSearcher",
    "ScriptedSearcher",
    "SEARCH_STRATEGIES",
]

#: Scan orders of the simulated searcher.
SEARCH_STRATEGIES: tuple[str, ...] = ("planes", "ordered")


@dataclass(frozen=True)
class Action:
    """One input of the searcher.

    Parameters
    ----------
    key : str
        The key (or input) pressed, as logged (``PageDown``, ``Up``, ``drag``, ``Enter``...).
    action : str
        One of :data:`experiment.viewer.state.ACTIONS`.
    delay_s : float >= 0
        Time since the previous input (simulated searchers) or 0 (live input: the clock moves
        by itself).
    box : (x, y, w, h) or None
        Zoom box.
    response : str
        The subject's words (``answer``; "" for ``pass``).
    """

    key: str
    action: str
    delay_s: float = 0.0
    box: tuple[int, int, int, int] | None = None
    response: str = ""


@dataclass(frozen=True, eq=False)
class Observation:
    """What a searcher knows before choosing its next input.

    Parameters
    ----------
    target : str
        The cued object.
    condition : str
    state : ViewerState
    view : Panes
        What the panes show (``view.grid``: the implant's lit electrodes).
    model : ViewerModel
        The depth range, planes and view size the keys work on.
    elapsed_s : float
        Time since the trial's onset, seconds.
    zoom_allowed : bool
    scene : adapter.Scene or None
        The trial's scene (a session with several scenes, or a new layout every trial).
    """

    target: str
    condition: str
    state: ViewerState
    view: Panes
    model: ViewerModel
    elapsed_s: float
    zoom_allowed: bool
    scene: adapter.Scene | None = None


@runtime_checkable
class Searcher(Protocol):
    """Who drives the viewer: a person (through the viewer) or a simulated searcher."""

    name: str

    def start(self, target: str, trial_index: int) -> None:
        """Prepare for a new trial (reset memory, draw the trial's random state)."""
        ...

    def next_action(self, obs: Observation) -> Action:
        """Return the next input given what is shown now."""
        ...


@dataclass(frozen=True)
class RecogniserParams:
    """Parameters of the simulated recogniser. All are ours, not the paper's.

    Parameters
    ----------
    retina_shape_px : (rows, cols)
        Grid the implant view and the templates are compared on (phosphenes blurred together).
    blur_sd_px : float >= 0
        Gaussian blur on that grid, samples.
    noise_sd : float >= 0
        Internal noise per sample, in SDs of the standardised image.
    min_r : float
        The best template's correlation must reach this to recognise anything.
    margin : float
        ... and beat the second best by this much.
    unsure_r : float
        Below ``min_r`` but at least this: unsure (worth a zoom).
    max_lit_fraction : float in (0, 1]
        A view with more of its cells lit than this shows no shape (defocused texture lights
        every cell) and is never recognised.
    """

    retina_shape_px: tuple[int, int] = (56, 70)
    blur_sd_px: float = 1.0
    noise_sd: float = 0.5
    min_r: float = 0.35
    margin: float = 0.1
    unsure_r: float = 0.2
    max_lit_fraction: float = 0.5


class EdgeRecogniser:
    """A model observer: correlates the implant view with each object's in-focus template.

    Templates are each object of the scene alone and in focus, passed through the same crop,
    de-clutter and compression as the view (its memory of what each object looks like through
    the implant). Simulated.

    Parameters
    ----------
    scene : adapter.Scene
        A scene with known objects: synthetic (it has the objects' appearances) or a recorded
        light field with a scene description (each target refocused at its plane, in its box).
    grid_px : (rows, cols)
    rng : numpy Generator, int or None
    params : RecogniserParams, optional
    """

    def __init__(self, scene, grid_px, *, rng=None, params: RecogniserParams | None = None):
        self.grid_px = tuple(grid_px)
        self.params = params or RecogniserParams()
        self.rng = np.random.default_rng(rng)
        self.use_scene(scene)

    def use_scene(self, scene) -> None:
        """Learn the objects of another scene (the next trial's); templates are rebuilt."""
        if not scene.appearances:
            raise ValueError(
                f"scene {scene.name!r} has no object appearances: the simulated recogniser "
                "needs a synthetic scene or a light field with a scene description "
                "(each target's name, plane and box)"
            )
        self.scene = scene
        self._templates: dict[tuple, tuple[list[str], np.ndarray]] = {}

    def _retina(self, grid: np.ndarray) -> np.ndarray:
        from experiment.observers import to_retina

        p = self.params
        return to_retina(grid, p.retina_shape_px, p.blur_sd_px).ravel()

    def templates(self, zoom) -> tuple[list[str], np.ndarray]:
        """Return the object names and their unit-norm templates for a zoom box (cached)."""
        key = tuple(zoom) if zoom is not None else None
        if key not in self._templates:
            names, rows = [], []
            for name, look in self.scene.appearances.items():
                g = adapter.object_edge_template(
                    look, self.grid_px, zoom_box_xywh=key, mask=self.scene.edge_masks.get(name)
                )
                r = self._retina(g)
                n = float(np.sqrt(np.sum(r * r)))
                names.append(name)
                rows.append(r / (n if n > 0 else 1.0))
            self._templates[key] = (names, np.vstack(rows))
        return self._templates[key]

    def correlations(self, grid: np.ndarray, zoom) -> dict[str, float]:
        """Return the correlation of the noisy implant view with each object's template."""
        names, t = self.templates(zoom)
        x = self._retina(grid)
        if self.params.noise_sd > 0:
            x = x + self.rng.normal(0.0, self.params.noise_sd, x.shape)
        x = x - x.mean()
        n = float(np.sqrt(np.sum(x * x)))
        r = np.sum(t * x, axis=1) / (n if n > 0 else 1.0)
        return {k: float(v) for k, v in zip(names, r, strict=True)}

    def suspect_box(self, name: str, grid: np.ndarray, shape_px: tuple[int, int]):
        """Return a zoom box (x, y, w, h) where ``name`` would be, or None.

        Its template's lit cells that are also lit in the view (all its template's cells when none
        are).
        """
        names, _ = self.templates(None)
        look = self.scene.appearances[name]
        tg = adapter.object_edge_template(look, self.grid_px, mask=self.scene.edge_masks.get(name))
        both = tg & np.asarray(grid, dtype=bool)
        return _lit_box(both if both.any() else tg, shape_px)

    def judge(self, grid: np.ndarray, zoom) -> tuple[str | None, bool, dict[str, float]]:
        """Return ``(recognised object or None, unsure, correlations)``."""
        r = self.correlations(grid, zoom)
        if float(np.mean(grid)) > self.params.max_lit_fraction:
            return None, False, r
        order = sorted(r, key=r.get, reverse=True)
        best = order[0]
        second = r[order[1]] if len(order) > 1 else -1.0
        p = self.params
        if r[best] >= p.min_r and r[best] - second >= p.margin:
            return best, False, r
        return None, r[best] >= p.unsure_r, r


def _lit_box(grid: np.ndarray, shape_px: tuple[int, int], pad_cells: int = 1):
    """Return the view-pixel box around the lit cells of a grid (None when no cell is lit)."""
    ys, xs = np.nonzero(grid)
    if ys.size == 0:
        return None
    gr, gc = grid.shape
    rows, cols = shape_px
    y0, y1 = max(0, ys.min() - pad_cells), min(gr, ys.max() + 1 + pad_cells)
    x0, x1 = max(0, xs.min() - pad_cells), min(gc, xs.max() + 1 + pad_cells)
    by0, by1 = int(y0 * rows // gr), int(np.ceil(y1 * rows / gr))
    bx0, bx1 = int(x0 * cols // gc), int(np.ceil(x1 * cols / gc))
    if bx1 - bx0 < 2 or by1 - by0 < 2 or (bx1 - bx0 >= cols and by1 - by0 >= rows):
        return None
    return bx0, by0, min(cols, bx1) - bx0, min(rows, by1) - by0


class SimulatedSearcher:
    """Scan planes in order until the model observer recognises the target (simulated).

    Past the last detected plane (or with none detected) both strategies go on with depth keys
    to the far end of the range, then pass.

    Parameters
    ----------
    recogniser : EdgeRecogniser
    strategy : {'planes', 'ordered'}
        ``planes``: jump between detected planes, nearest first (PageDown); ``ordered``: step
        the depth from near to far (Down).
    rng : numpy Generator, int or None
        Times per key and per look.
    key_s, look_s, say_s : float > 0
        Median simulated time of a key press, of looking at a new view, and of saying the
        answer, seconds (ours).
    """

    def __init__(
        self,
        recogniser: EdgeRecogniser,
        strategy: str = "planes",
        *,
        rng=None,
        key_s: float = 0.4,
        look_s: float = 1.0,
        say_s: float = 1.5,
    ) -> None:
        if strategy not in SEARCH_STRATEGIES:
            raise ValueError(
                f"strategy must be one of {', '.join(SEARCH_STRATEGIES)}, got {strategy!r}"
            )
        self.recogniser = recogniser
        self.strategy = strategy
        self.name = f"sim:{strategy}"
        self.seed = rng
        self.key_s, self.look_s, self.say_s = key_s, look_s, say_s
        self.rng = np.random.default_rng(rng)
        self._zoomed_here = False
        self._visits = 0
        self._last_r: dict[str, float] = {}

    def start(self, target: str, trial_index: int) -> None:
        """Reset for a trial; the trial's randomness depends only on (seed, trial index)."""
        base = self.seed if isinstance(self.seed, int) else 0
        seq = np.random.SeedSequence([int(base), 14, int(trial_index)])
        self.rng = np.random.default_rng(seq)
        self.recogniser.rng = np.random.default_rng(seq.spawn(1)[0])
        self._zoomed_here = False
        self._visits = 0
        self._last_r: dict[str, float] = {}

    def _t(self, median_s: float) -> float:
        return float(median_s * np.exp(0.3 * self.rng.standard_normal()))

    def _move(self, obs: Observation) -> Action:
        m, st = obs.model, obs.state
        if self.strategy == "planes":
            # jump between the detected planes; past the last one, sweep the rest by depth keys
            last = m.planes_px[-1] if m.planes_px else m.near_px
            if st.disparity_px > last + 1e-9:
                return Action("PageDown", "plane_next", self._t(self.key_s))
        if st.disparity_px <= m.far_px + 1e-9:
            return Action("Escape", "pass", self._t(self.key_s))
        return Action("Down", "depth_far", self._t(self.key_s))

    def next_action(self, obs: Observation) -> Action:
        """Look at the view; answer, zoom, un-zoom or move on."""
        if obs.scene is not None and obs.scene is not self.recogniser.scene:
            self.recogniser.use_scene(obs.scene)
        look = self._t(self.look_s)
        found, unsure, self._last_r = self.recogniser.judge(obs.view.grid, obs.state.zoom)
        if found is not None and found == obs.target:
            return Action("Enter", "answer", look + self._t(self.say_s), response=found)
        if obs.state.zoom is not None:
            return Action("Escape", "unzoom", look + self._t(self.key_s))
        r_target = self._last_r.get(obs.target, -1.0)
        if (
            (unsure or r_target >= self.recogniser.params.unsure_r)
            and obs.zoom_allowed
            and not self._zoomed_here
        ):
            box = self.recogniser.suspect_box(obs.target, obs.view.grid, obs.model.shape_px)
            if box is not None:
                self._zoomed_here = True
                return Action("drag", "zoom", look + self._t(self.key_s), box=box)
        self._zoomed_here = False
        a = self._move(obs)
        return Action(a.key, a.action, look + a.delay_s, a.box, a.response)


class ScriptedSearcher:
    """Replay a fixed list of actions (tests, demos). The list is reused for every trial."""

    def __init__(self, actions: list[Action], name: str = "scripted") -> None:
        self.actions = list(actions)
        self.name = name
        self._i = 0

    def start(self, target: str, trial_index: int) -> None:
        """Rewind the script."""
        self._i = 0

    def next_action(self, obs: Observation) -> Action:
        """Return the next scripted action (a pass when the script is used up)."""
        if self._i >= len(self.actions):
            return Action("Escape", "pass", 1.0)
        a = self.actions[self._i]
        self._i += 1
        return a
