"""The ``exemplar`` observer: recognises objects from *other* exemplars of their category.

What the observer knows
-----------------------
Only what a subject brings to the study or is given by the protocol:

* **Category knowledge** comes from a *knowledge set*: a stimulus set of **other exemplars** of
  the object categories, never the test stimuli. For the synthetic study it is another
  ``confocal stimuli synth`` rendering (another seed: other pose, size, colour, background and
  lens draw) of the same kinds, built by the same pipeline; for real photo sets it is a
  held-out set of photos. Each category (object ``name`` in ``objects.csv``, every role) is
  remembered as the oriented-edge features of its exemplars' full-resolution de-cluttered
  images, and of their mirror images: people recognise a left-right reversed object as readily
  as the original (Biederman & Cooper 1991), and a screwdriver drawn pointing left is still a
  screwdriver. The vocabulary is every category of the knowledge set (main *and* training
  kinds), so the observer can also name an object that is not in the test.
* **The decision criterion** is set in the protocol's training phase: the observer is shown the
  training objects' edge images at every level and condition (as subjects were, Jung et al.
  2015, Sec. 3.2) and places its criterion where the expected training score (a correct name
  +1, a wrong one ``-wrong_cost``) is highest. No parameter is taken from the paper's results.

The model
---------
1. **Front end: the image the subject sees.** The stimulus, at any level, is shown at the
   presenter's geometry (every level fills the same ``image_width_cm x image_height_cm`` at
   ``viewing_distance_cm``, pixel replication as the presenter's NEAREST filter), integrated over
   retinal samples ``1/samples_per_deg`` deg wide (an exact area average of the piecewise
   constant screen image) and blurred by a Gaussian of SD ``blur_deg`` degrees. With 0.1 deg the
   front end passes spatial frequencies up to ~1.9 c/deg at half amplitude, i.e. ~19 cycles per
   10 deg object, the band object recognition relies on (Parish & Sperling 1991; Braje, Tjan &
   Legge 1995).
2. **Features: histograms of oriented gradients** (Dalal & Triggs 2005; ``skimage.feature.hog``)
   with cells of ``cell_deg`` degrees, ``orientations`` bins and L2-Hys block normalisation,
   centred and scaled to unit length, so a stimulus' similarity to an exemplar is the Pearson
   correlation of their HOG vectors. A category's similarity is its best exemplar's (an
   exemplar model, Nosofsky 1986, with a max rule).
3. **Internal noise.** Each category's similarity gets independent Gaussian noise of SD
   ``noise_sd`` on every trial (late, decision noise: Thurstone 1927; Green & Swets 1966).
4. **Decision rule.** The best category is named when its noisy similarity exceeds the second
   best's by more than the criterion; otherwise the observer passes (or describes the shape).
   Clutter adds edges that match no category and so shrinks that margin; low resolution blurs
   categories together. Both effects come from the pixels.

Because the noise-free similarities depend on the image alone, they are cached per image
(module-level, shared by the simulated subjects of one run); only the noise is drawn per trial.

Limitations
-----------
It chooses among the knowledge set's categories only (23 in the demo, the kinds subjects were
told about), and its exemplars come from the same drawing generator as the test objects, so
within-category variation is far smaller than among real mugs or lamps. It therefore recognises
de-cluttered objects at much lower resolution than the paper's subjects did; what it shows is the
*direction* of the effects of clutter and resolution and how they follow from the pixels, not
the paper's absolute thresholds. In our runs when the model was built, the de-cluttered 50 %
point stayed near 100-270 px over the blur, cell size and noise values we tried, while the
cluttered one moved from ~650 to ~28,000 px: the cluttered threshold depends strongly on these
parameters and on the three training objects that set the criterion.

References
----------
Biederman I, Cooper EE (1991). Evidence for complete translational and reflectional invariance in
visual object priming. Perception 20, 585-593.
Braje WL, Tjan BS, Legge GE (1995). Human efficiency for recognizing and detecting low-pass
filtered objects. Vision Research 35, 2955-2966.
Dalal N, Triggs B (2005). Histograms of oriented gradients for human detection. CVPR, 886-893.
Green DM, Swets JA (1966). Signal detection theory and psychophysics. Wiley.
Jung JH, Aloni D, Yitzhaky Y, Peli E (2015). Active confocal imaging for visual prostheses.
Vision Research 111, 182-196 (Sec. 3.1: display geometry; Sec. 3.2: training and procedure).
Nosofsky RM (1986). Attention, similarity, and the identification-categorization relationship.
J Exp Psychol Gen 115, 39-57.
Parish DH, Sperling G (1991). Object spatial frequencies, retinal spatial frequencies, noise,
and the efficiency of letter discrimination. Vision Research 31, 1399-1415.
Thurstone LL (1927). A law of comparative judgment. Psychological Review 34, 273-286.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from experiment.interfaces import Answer
from experiment.observers.base import (
    AnswerParams,
    SimulatedObserver,
    check_limits,
    response_time_s,
)
from experiment.session.scoring import normalize
from experiment.session.stimset import StimulusSet
from stimuli.jung2015 import IMAGE_SIZE_CM, VIEWING_DISTANCE_CM

__all__ = [
    "ExemplarParams",
    "ExemplarObserver",
    "Knowledge",
    "load_knowledge",
    "knowledge_cache_entries",
    "add_knowledge_cache_entries",
    "best_criterion",
    "retinal_image",
    "hog_features",
    "image_sha256",
]

#: Most images whose noise-free similarities are cached (a demo has ~400 distinct images).
_CACHE_MAX = 20_000
_SIM_CACHE: dict[tuple, np.ndarray] = {}
_KNOWLEDGE_CACHE: dict[tuple, Knowledge] = {}


def image_sha256(image: np.ndarray) -> str:
    """Return the SHA-256 of an image's pixels (shape, dtype and values, not the file bytes)."""
    a = np.ascontiguousarray(image)
    h = hashlib.sha256(f"{a.shape}|{a.dtype.str}|".encode())
    h.update(a.tobytes())
    return h.hexdigest()


def _area_average(a: np.ndarray, n_out: int, axis: int) -> np.ndarray:
    """Average a piecewise-constant image over ``n_out`` equal cells along ``axis`` (exact).

    Uses the running integral of the image, linear inside each pixel, so any ratio of sizes
    (enlarging or reducing) is handled the same way and without a matrix product.
    """
    a = np.moveaxis(a, axis, 0)
    n_in = a.shape[0]
    integral = np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0)], axis=0)
    edges = np.linspace(0.0, n_in, n_out + 1)
    i0 = np.minimum(np.floor(edges).astype(int), n_in - 1)
    frac = (edges - i0)[:, None]
    at_edges = integral[i0] + frac * (integral[i0 + 1] - integral[i0])
    out = np.diff(at_edges, axis=0) * (n_out / n_in)
    return np.moveaxis(out, 0, axis)


def _visual_angle_deg(size_cm: float, distance_cm: float) -> float:
    return 2.0 * math.degrees(math.atan(size_cm / (2.0 * distance_cm)))


def retinal_image(
    image: np.ndarray,
    image_size_deg: tuple[float, float],
    *,
    samples_per_deg: float,
    blur_deg: float,
) -> np.ndarray:
    """Return the image as the observer's eye samples it: shown full size, averaged, blurred.

    Parameters
    ----------
    image : ndarray of shape (rows, cols), bool or float in [0, 1]
        The stimulus at its own resolution (any level).
    image_size_deg : (height_deg, width_deg)
        Visual angle the image fills on screen (every level fills the same area).
    samples_per_deg : float > 0
        Retinal sampling density, samples per degree.
    blur_deg : float >= 0
        SD of the Gaussian optical blur, degrees.

    Returns
    -------
    ndarray of shape (round(height_deg * samples_per_deg), round(width_deg * samples_per_deg)),
    float64 in [0, 1]

    Examples
    --------
    >>> img = np.zeros((2, 2), bool); img[0, 0] = True
    >>> retinal_image(img, (1.0, 1.0), samples_per_deg=4, blur_deg=0)[:, :2].tolist()
    [[1.0, 1.0], [1.0, 1.0], [0.0, 0.0], [0.0, 0.0]]
    """
    from scipy.ndimage import gaussian_filter

    a = np.asarray(image)
    if a.ndim != 2:
        raise ValueError(f"image must be 2-D (rows, cols), got shape {a.shape}")
    if samples_per_deg <= 0:
        raise ValueError(f"samples_per_deg must be > 0, got {samples_per_deg!r}")
    if blur_deg < 0:
        raise ValueError(f"blur_deg must be >= 0, got {blur_deg!r}")
    rows = max(2, int(round(image_size_deg[0] * samples_per_deg)))
    cols = max(2, int(round(image_size_deg[1] * samples_per_deg)))
    g = _area_average(_area_average(a.astype(np.float64), rows, 0), cols, 1)
    if blur_deg > 0:
        g = gaussian_filter(g, blur_deg * samples_per_deg, mode="nearest")
    return g


def hog_features(retina: np.ndarray, *, cell_px: int, orientations: int) -> np.ndarray:
    """Return a retinal image's HOG vector, centred and scaled to unit length.

    Parameters
    ----------
    retina : ndarray of shape (rows, cols), float
        Output of :func:`retinal_image`.
    cell_px : int >= 2
        HOG cell side, retinal samples.
    orientations : int >= 2
        Orientation bins (unsigned gradients, 0-180 deg).

    Returns
    -------
    ndarray of shape (n_features,), float64
        All zeros for an image without gradients.

    References
    ----------
    Dalal & Triggs (2005): 2x2-cell blocks, L2-Hys normalisation.
    """
    from skimage.feature import hog

    f = hog(
        retina,
        orientations=orientations,
        pixels_per_cell=(cell_px, cell_px),
        cells_per_block=(2, 2),
        block_norm="L2-Hys",
        feature_vector=True,
    ).astype(np.float64)
    f = f - f.mean()
    n = float(np.sqrt(np.sum(f * f)))
    return f / n if n > 0 else f


@dataclass(frozen=True)
class ExemplarParams(AnswerParams):
    """Parameters of the ``exemplar`` observer (see the module docstring for the model).

    The answer parameters (``lapse``, ``p_use``, ``p_shape``, ``median_rt_s``) are those of
    :class:`~experiment.observers.base.AnswerParams`.

    All values except the display geometry are ours, not the paper's; none was tuned to the
    paper's results.

    Parameters
    ----------
    knowledge : str or tuple of str
        Folder of the knowledge set: a stimulus set of *other* exemplars of the categories (for
        the synthetic study, ``confocal stimuli synth`` with another seed, then ``stimuli
        build``). Several folders are pooled: each kind is then remembered from several
        renderings (pose, size, style), as a person knows many mugs. Required.
    exemplar_level : int >= 1 or None
        Level of the exemplar images remembered. None: the knowledge set's highest level (full
        resolution; what a person remembers of an object is not a compressed picture).
    exemplar_condition : {'decluttered', 'cluttered'}
        Which exemplar image is remembered. De-cluttered: the object alone, the knowledge of
        its shape; cluttered would add the exemplar's own background, which no test stimulus
        shares.
    mirror : bool
        Also remember each exemplar's left-right mirror image (Biederman & Cooper 1991).
    image_width_cm, image_height_cm, viewing_distance_cm : float > 0
        The presenter's geometry. Defaults: Jung et al. 2015, Sec. 3.1 (14.6 x 9.7 cm at 80 cm,
        10.4 x 6.9 deg).
    samples_per_deg : float > 0
        Retinal sampling density. 10/deg: Nyquist 5 c/deg, above what ``blur_deg`` passes.
    blur_deg : float >= 0
        SD of the Gaussian optical blur, degrees. 0.1 deg keeps ~19 cycles per 10 deg object
        (Parish & Sperling 1991; Braje et al. 1995).
    cell_deg : float > 0
        HOG cell side, degrees (0.6 deg: ~16 cells across a 10 deg object, twice Dalal &
        Triggs' 8 cells across a 64 px person window, as objects have more parts).
    orientations : int >= 2
        HOG orientation bins (Dalal & Triggs 2005: 9).
    noise_sd : float >= 0
        SD of the internal (decision) noise added to each category's similarity, correlation
        units. 0.02 is about a tenth of the spread of similarities between categories.
    criterion : float or None
        Margin (best minus second best noisy similarity) above which the observer names the
        best category. None: set from the training phase (see ``wrong_cost``).
    wrong_cost : float > 0
        Cost of a wrong name relative to the gain of a right one, used to set the criterion
        from the training phase (1: answer when a name is more likely right than wrong).
    calibration_repeats : int >= 1
        Noise draws per training stimulus when setting the criterion.
    """

    knowledge: str | tuple[str, ...] | None = None
    exemplar_level: int | None = None
    exemplar_condition: str = "decluttered"
    mirror: bool = True
    image_width_cm: float = IMAGE_SIZE_CM[1]
    image_height_cm: float = IMAGE_SIZE_CM[0]
    viewing_distance_cm: float = VIEWING_DISTANCE_CM
    samples_per_deg: float = 10.0
    blur_deg: float = 0.1
    cell_deg: float = 0.6
    orientations: int = 9
    noise_sd: float = 0.02
    criterion: float | None = None
    wrong_cost: float = 1.0
    calibration_repeats: int = 20

    def __post_init__(self) -> None:
        k = self.knowledge
        if isinstance(k, (list, tuple)):
            folders = tuple(str(f) for f in k)
            if len(folders) == 1:
                folders = folders[0]
            object.__setattr__(self, "knowledge", folders)
            k = folders
        if (
            k is None
            or not all(str(f).strip() for f in (k if isinstance(k, tuple) else [k]))
            or (isinstance(k, tuple) and not k)
        ):
            raise ValueError(
                "knowledge must be the folder of a stimulus set of other exemplars of the "
                "categories (e.g. stimuli synth with another seed, then stimuli build), or a "
                f"list of such folders, got {k!r}"
            )
        check_limits(
            self,
            {
                "image_width_cm": "> 0",
                "image_height_cm": "> 0",
                "viewing_distance_cm": "> 0",
                "samples_per_deg": "> 0",
                "blur_deg": ">= 0",
                "noise_sd": ">= 0",
                "wrong_cost": "> 0",
                "calibration_repeats": ">= 1",
            },
        )
        super().__post_init__()
        if not self.cell_deg * self.samples_per_deg >= 2:
            raise ValueError(
                f"cell_deg must span >= 2 retinal samples (>= {2 / self.samples_per_deg:g} deg), "
                f"got {self.cell_deg!r}"
            )
        lv = self.exemplar_level
        if lv is not None and (isinstance(lv, bool) or int(lv) != lv or lv < 1):
            raise ValueError(f"exemplar_level must be a level >= 1 or None, got {lv!r}")
        if self.exemplar_condition not in ("decluttered", "cluttered"):
            raise ValueError(
                "exemplar_condition must be 'decluttered' or 'cluttered', "
                f"got {self.exemplar_condition!r}"
            )

    @property
    def image_size_deg(self) -> tuple[float, float]:
        """(height, width) of the shown image, degrees of visual angle."""
        d = self.viewing_distance_cm
        return (
            _visual_angle_deg(self.image_height_cm, d),
            _visual_angle_deg(self.image_width_cm, d),
        )

    def frontend_key(self) -> tuple:
        """Return the parameters that fix an image's noise-free features (the cache key)."""
        return (
            round(self.image_size_deg[0], 9),
            round(self.image_size_deg[1], 9),
            self.samples_per_deg,
            self.blur_deg,
            self.cell_deg,
            self.orientations,
        )

    def features(self, image: np.ndarray) -> np.ndarray:
        """Return an image's unit-length HOG vector through this front end."""
        retina = retinal_image(
            image,
            self.image_size_deg,
            samples_per_deg=self.samples_per_deg,
            blur_deg=self.blur_deg,
        )
        cell = max(2, int(round(self.cell_deg * self.samples_per_deg)))
        return hog_features(retina, cell_px=cell, orientations=self.orientations)


@dataclass(frozen=True)
class Knowledge:
    """What the observer remembers: one feature row per exemplar image, and where each came from.

    Parameters
    ----------
    categories : tuple of str
        Category names (the vocabulary), in knowledge-set order; objects whose names are equal
        after :func:`experiment.session.scoring.normalize` are one category.
    features : ndarray of shape (n_exemplars, n_features)
        Unit-length HOG rows.
    category_of_row : ndarray of shape (n_exemplars,), int
        Index into ``categories`` of each row.
    root : str
        Knowledge-set folder.
    manifest_sha256 : str
        SHA-256 of its ``manifest.csv``.
    sources : tuple of dict
        One per exemplar image read: ``object``, ``name``, ``path``, ``file_sha256`` (from the
        manifest, checked), ``pixel_sha256`` (:func:`image_sha256` of the pixels as read).
    info : dict
        The knowledge set's ``stimulus_set.json``.
    synth : dict or None
        ``generator``, ``seed`` and ``version`` from the ``synth.json`` of the photo pairs it
        was built from, when they were synthetic and are still there; else None.
    """

    categories: tuple[str, ...]
    features: np.ndarray
    category_of_row: np.ndarray
    root: str
    manifest_sha256: str
    sources: tuple[dict, ...]
    info: dict
    synth: dict | None = None

    def similarities(self, feature: np.ndarray, tau: float = 0.0) -> np.ndarray:
        """Return each category's similarity to ``feature``, pooled over its exemplars.

        Parameters
        ----------
        feature : ndarray of shape (n_features,)
        tau : float >= 0
            0: the best exemplar's correlation (max rule). Above 0: the summed similarity of
            the generalised context model (Nosofsky 1986), ``tau * log(mean(exp(r / tau)))``
            over the category's exemplar correlations ``r``; the max as tau -> 0, the mean as
            tau -> infinity.

        Examples
        --------
        >>> k = Knowledge(("a",), np.eye(2), np.array([0, 0]), "", "", (), {})
        >>> k.similarities(np.array([0.2, 0.4])).tolist()
        [0.4]
        >>> round(float(k.similarities(np.array([0.2, 0.4]), tau=100.0)[0]), 3)
        0.3
        """
        r = self.features @ feature
        out = np.full(len(self.categories), -np.inf)
        np.maximum.at(out, self.category_of_row, r)
        if tau > 0:
            e = np.zeros(len(self.categories))
            np.add.at(e, self.category_of_row, np.exp((r - out[self.category_of_row]) / tau))
            n = np.bincount(self.category_of_row, minlength=len(self.categories))
            out = out + tau * np.log(e / n)
        return out


def best_criterion(margins: np.ndarray, gains: np.ndarray) -> float:
    """Return the criterion that maximises the summed gain of the trials it lets through.

    A trial is answered when its margin exceeds the criterion; it then earns its gain
    (+1 for a right name, ``-wrong_cost`` for a wrong one); passing earns 0.

    Parameters
    ----------
    margins : ndarray of shape (n,)
        Noisy margins (best minus second-best similarity) of the training trials.
    gains : ndarray of shape (n,)
        What answering each trial would earn.

    Returns
    -------
    float
        Midway between the last margin answered and the first one passed (just above the
        largest margin when answering nothing is best; ties go to the higher criterion).

    Examples
    --------
    >>> best_criterion(np.array([0.5, 0.25, 0.125, 0.0625]), np.array([1.0, 1.0, -1.0, 1.0]))
    0.1875
    """
    m = np.asarray(margins, dtype=float)
    g = np.asarray(gains, dtype=float)
    if m.ndim != 1 or m.shape != g.shape or m.size == 0:
        raise ValueError(
            f"margins and gains must be 1-D arrays of one non-zero length, got shapes "
            f"{m.shape} and {g.shape}"
        )
    order = np.argsort(-m, kind="stable")
    m, g = m[order], g[order]
    score = np.concatenate([[0.0], np.cumsum(g)])  # score[k]: answer the k largest margins
    k = int(np.argmax(score))  # the first maximum: the fewest answers, the higher criterion
    if k == 0:
        return float(m[0]) + 1e-9
    if k == len(m):
        return float(m[-1]) - 1e-9
    return float(0.5 * (m[k - 1] + m[k]))


def _synth_provenance(info: dict) -> dict | None:
    """Return ``generator``, ``seed``, ``version`` of the synthetic pairs a set was built from."""
    pairs = info.get("pairs")
    if isinstance(pairs, dict):  # recorded in the set since it stopped holding host paths
        synth = pairs.get("synth")
        return dict(synth) if isinstance(synth, dict) else None
    if not isinstance(pairs, str):
        return None
    p = Path(pairs) / "synth.json"
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return {k: d.get(k) for k in ("generator", "seed", "version")}


def load_knowledge(params: ExemplarParams) -> Knowledge:
    """Read the knowledge set named by ``params.knowledge`` and compute its exemplar features.

    Parameters
    ----------
    params : ExemplarParams

    Returns
    -------
    Knowledge
        Cached by (folder, manifest sha256, front end, exemplar choice).

    Raises
    ------
    StimulusSetError
        The folder is not a stimulus set, an exemplar image is missing or changed, or it has no
        image at ``exemplar_level`` / ``exemplar_condition``.
    """
    if isinstance(params.knowledge, tuple):
        return _pooled_knowledge(
            [load_knowledge(replace(params, knowledge=f)) for f in params.knowledge]
        )
    ks = StimulusSet.load(params.knowledge)
    level = max(ks.levels()) if params.exemplar_level is None else int(params.exemplar_level)
    key = (
        str(ks.root),
        ks.manifest_sha256,
        params.frontend_key(),
        level,
        params.exemplar_condition,
        params.mirror,
    )
    if key in _KNOWLEDGE_CACHE:
        return _KNOWLEDGE_CACHE[key]
    categories: list[str] = []
    rows, cats, sources = [], [], []
    for oid, info in ks.objects.items():
        rec = ks.get(oid, params.exemplar_condition, level)
        ks.verify([rec])
        img = ks.load_image(rec)
        keys = [normalize(c) for c in categories]
        if normalize(info.name) not in keys:
            categories.append(info.name)
            keys.append(normalize(info.name))
        views = (img, img[:, ::-1]) if params.mirror else (img,)
        for v in views:
            rows.append(params.features(v))
            cats.append(keys.index(normalize(info.name)))
        sources.append(
            {
                "object": oid,
                "name": info.name,
                "path": rec.path,
                "file_sha256": rec.sha256,
                "pixel_sha256": image_sha256(img),
            }
        )
    k = Knowledge(
        categories=tuple(categories),
        features=np.vstack(rows),
        category_of_row=np.asarray(cats, dtype=int),
        root=str(ks.root),
        manifest_sha256=ks.manifest_sha256,
        sources=tuple(sources),
        info=dict(ks.info),
        synth=_synth_provenance(ks.info),
    )
    _KNOWLEDGE_CACHE[key] = k
    return k


def knowledge_cache_entries(folders: list[str]) -> list[tuple[tuple, Knowledge]]:
    """Return this process' cached :func:`load_knowledge` results for ``folders``.

    Their keys (folder, manifest sha256, front end, exemplar choice) come with them, to hand to
    another process (:func:`add_knowledge_cache_entries`).
    """
    roots = {str(StimulusSet.load(f).root) for f in folders}
    return [(k, v) for k, v in _KNOWLEDGE_CACHE.items() if k[0] in roots]


def add_knowledge_cache_entries(entries: list[tuple[tuple, Knowledge]]) -> None:
    """Add :func:`knowledge_cache_entries` read in another process to this one's cache.

    The same computation, so a later :func:`load_knowledge` of those folders returns the same
    features without computing them again.
    """
    for key, k in entries:
        _KNOWLEDGE_CACHE[tuple(key)] = k


def _pooled_knowledge(parts: list[Knowledge]) -> Knowledge:
    """One knowledge of several sets: categories merged by normalised name, rows stacked."""
    categories: list[str] = []
    keys: list[str] = []
    cats = []
    for k in parts:
        for c in k.categories:
            if normalize(c) not in keys:
                categories.append(c)
                keys.append(normalize(c))
        remap = np.array([keys.index(normalize(c)) for c in k.categories], dtype=int)
        cats.append(remap[k.category_of_row])
    synths = [k.synth for k in parts]
    return Knowledge(
        categories=tuple(categories),
        features=np.vstack([k.features for k in parts]),
        category_of_row=np.concatenate(cats),
        root=";".join(k.root for k in parts),
        manifest_sha256=hashlib.sha256(
            "|".join(k.manifest_sha256 for k in parts).encode()
        ).hexdigest(),
        sources=tuple(src for k in parts for src in k.sources),
        info={"pooled": [k.info for k in parts]},
        synth=(
            {"seed": [s.get("seed") for s in synths], "parts": synths}
            if all(isinstance(s, dict) for s in synths)
            else None
        ),
    )


class ExemplarObserver(SimulatedObserver):
    """The ``exemplar`` simulated observer (a :class:`~experiment.interfaces.Responder`).

    Construction loads the knowledge set and, unless ``params.criterion`` is given, runs the
    protocol's training phase on the stimulus set's training objects to set the criterion.

    Parameters
    ----------
    stimset : StimulusSet
        The test stimulus set (object names for scoring; its training objects for the criterion).
    subject : str
        Subject code (the rater name and provenance).
    rng : numpy.random.Generator, int or None
        Internal noise, training phase first, then the trials.
    params : ExemplarParams

    Attributes
    ----------
    knowledge : Knowledge
    criterion : float
        The criterion in use.
    calibration : dict
        How it was set: training stimuli (with pixel sha256), score, answered share.

    Raises
    ------
    ValueError
        ``criterion`` is None and the stimulus set has no training objects.
    """

    name = "exemplar"
    model = "HOG exemplar matcher with internal noise (experiment.observers.exemplar)"

    @staticmethod
    def params_class() -> ExemplarParams:
        """Refuse to guess the knowledge set: the observer needs ``params``."""
        raise ValueError("params must be an ExemplarParams with knowledge=FOLDER, got None")

    def _prepare(self) -> None:
        params = self.params
        self.knowledge = load_knowledge(params)
        self.calibration: dict[str, Any] = {}
        if params.criterion is not None:
            self.criterion = float(params.criterion)
            self.calibration = {"method": "given"}
        else:
            self.criterion = self._calibrate()

    # -- similarities ---------------------------------------------------------------------------

    def similarities(self, image: np.ndarray) -> np.ndarray:
        """Return the noise-free similarity of ``image`` to every category (cached per image)."""
        tau = float(getattr(self.params, "exemplar_tau", 0.0))
        key = (self.knowledge.root, self.knowledge.manifest_sha256, self.params.frontend_key(),
               self.params.exemplar_level, self.params.exemplar_condition, self.params.mirror,
               tau, image_sha256(image))  # fmt: skip
        s = _SIM_CACHE.get(key)
        if s is None:
            s = self.knowledge.similarities(self.params.features(image), tau=tau)
            if len(_SIM_CACHE) >= _CACHE_MAX:
                _SIM_CACHE.clear()
            _SIM_CACHE[key] = s
        return s

    def _decide(self, s: np.ndarray) -> tuple[int, float]:
        """Add internal noise; return (best category, margin over the second best)."""
        noisy = s + self.rng.normal(0.0, self.params.noise_sd, s.shape)
        order = np.argsort(noisy)[::-1]
        margin = float(noisy[order[0]] - noisy[order[1]]) if len(order) > 1 else float("inf")
        return int(order[0]), margin

    def _is_correct(self, category: int, object_id: str) -> bool:
        obj = self.stimset.objects[object_id]
        names = {normalize(obj.name), *(normalize(s) for s in obj.synonyms)}
        return normalize(self.knowledge.categories[category]) in names

    # -- the training phase ---------------------------------------------------------------------

    def _calibrate(self) -> float:
        """Set the criterion from the training phase.

        Training objects, every level, both conditions: the criterion that maximises the expected
        training score.
        """
        p = self.params
        recs = [
            r
            for r in self.stimset.records
            if self.stimset.objects[r.object].role == "training"
            and r.condition in ("cluttered", "decluttered")
        ]
        if not recs:
            raise ValueError(
                f"criterion must be given: stimulus set {self.stimset.root} has no training "
                "objects to set it from"
            )
        margins, gains, shown = [], [], []
        for r in recs:
            img = self.stimset.load_image(r)
            s = self.similarities(img)
            shown.append({"object": r.object, "condition": r.condition, "level": r.level,
                          "file_sha256": r.sha256, "pixel_sha256": image_sha256(img)})  # fmt: skip
            for _ in range(int(p.calibration_repeats)):
                best, m = self._decide(s)
                margins.append(m)
                gains.append(1.0 if self._is_correct(best, r.object) else -p.wrong_cost)
        m = np.asarray(margins)
        g = np.asarray(gains)
        crit = best_criterion(m, g)
        answered = m > crit
        self.calibration = {
            "method": "training phase: criterion maximising (correct - wrong_cost * wrong)",
            "n_training_stimuli": len(recs),
            "repeats": int(p.calibration_repeats),
            "answered": float(answered.mean()),
            "correct_when_answered": (float((g[answered] > 0).mean()) if answered.any() else None),
            "stimuli": shown,
        }
        return crit

    # -- responding -----------------------------------------------------------------------------

    def respond(self, trial: Any, image: np.ndarray) -> Answer:
        """Name the best-matching category when it stands out by the criterion, else pass."""
        p = self.params
        rt = response_time_s(self.rng, p.median_rt_s)
        image = np.asarray(image)
        if image.ndim == 3:  # a colour training photo: its luminance (Rec. 709), as grey photos
            image = image[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
        best, margin = self._decide(self.similarities(image))
        if self.rng.random() < p.lapse or margin <= self.criterion:
            shape = "something with straight edges"
            return self._answer(trial, rt, recognized=False, p_shape=p.p_shape, shape_text=shape)
        if self._is_correct(best, trial.object):
            return self._answer(trial, rt, recognized=True, p_use=p.p_use)
        return self._answer(trial, rt, recognized=False, wrong=self.knowledge.categories[best])

    def _provenance(self) -> dict[str, Any]:
        k = self.knowledge
        return {
            "criterion": self.criterion,
            "calibration": {kk: v for kk, v in self.calibration.items()},
            "knowledge": {
                "root": k.root,
                "manifest_sha256": k.manifest_sha256,
                "synth": k.synth,
                "categories": list(k.categories),
                "exemplars": list(k.sources),
            },
        }
