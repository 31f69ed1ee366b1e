"""Simulated observers: responders that answer headless sessions (dry runs, pilots, CI).

Four observers are registered by name (:data:`OBSERVERS`, :func:`make_observer`). Every one
is a simulation: its sessions are logged with ``responder = 'sim:<name>'`` and, through
:func:`describe_observer`, with its parameters and the data its knowledge came from.

``calibrated`` (:mod:`experiment.observers.calibration`; the demo's default)
    The exemplar observer with a person's decision stage (normalised responses, internal
    noise, an open-set criterion that passes on kinds it does not know, a criterion lower for
    kinds it has already named in the session, lapses); its criterion fitted to the paper's
    cluttered condition only; the de-cluttered numbers it gives are a prediction.

``exemplar`` (:mod:`experiment.observers.exemplar`)
    Looks at the image and recognises it from *other* exemplars of each category (another
    rendering of the same kinds, or held-out photos), never from the test stimuli: a HOG
    exemplar matcher behind a front end at the presenter's geometry, with internal noise and a
    criterion set in the protocol's training phase. See that module for the model and its
    references.

``logistic``
    Draws "recognised or not" from the logistic model the paper fitted (Jung et al. 2015,
    Sec. 3.2.2), plus a subject effect, object effects and lapses::

        logit p = b0 + ln(OR_bg) * decluttered + ln(OR_px) * log10(pixels) + u_subject + v_object
        P(recognised) = (1 - lapse) * p

    ``b0`` is set so that the 50 % point of the cluttered condition is ``x50_cluttered_px``
    (for u = v = 0); the de-cluttered 50 % point follows from the odds ratio:
    ``10 ** (log10(x50_cluttered_px) - ln(OR_bg) / ln(OR_px))`` (3,470 px with the defaults, the
    paper's Weibull fit gave 3,532 px). Photos (training) are always recognised unless a lapse.
    It gives the paper's odds ratios back by construction. The paper's thresholds are Weibull
    fits to all subjects' and objects' trials pooled, which sit above the average object's 50 %
    point (10,260 px for an average object at 8,695 px with these effects); ``confocal demo``
    therefore sets ``x50_cluttered_px`` to the average-object point whose pooled Weibull is at
    8,695 px (about 7,470 px; :mod:`experiment.observers.pooled`).

``model``
    Looks at the image, but its templates are the test set's *own* de-cluttered images (at a
    fixed level, or at the stimulus' level): it knows every test object's picture, so the
    de-cluttered advantage is partly built in. Kept for comparison with ``exemplar``. The shown
    stimulus plus Gaussian pixel noise is compared, by Pearson correlation, with every candidate
    object's template; the best match is answered if it stands out by a criterion, else the
    observer passes.

All draw every random number from the ``rng`` they are given (the session's child generator);
the subject and object effects of ``logistic`` come from ``population_seed`` so the same object
is equally hard for every simulated subject.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, fields, is_dataclass
from typing import Any

import numpy as np

from experiment.interfaces import Answer
from experiment.observers.base import (
    AnswerParams,
    SimulatedObserver,
    check_limits,
    response_time_s,
)
from experiment.observers.calibration import CalibratedObserver, CalibratedParams
from experiment.observers.exemplar import ExemplarObserver, ExemplarParams
from experiment.session.stimset import PHOTO_CONDITIONS, StimulusSet

__all__ = [
    "CalibratedParams",
    "CalibratedObserver",
    "ExemplarParams",
    "ExemplarObserver",
    "LogisticParams",
    "LogisticResponder",
    "TemplateParams",
    "TemplateObserver",
    "OBSERVERS",
    "make_observer",
    "describe_observer",
    "to_retina",
]

#: Odds ratio of recognition, de-cluttered vs cluttered. Source: Jung et al. 2015, Sec. 3.2.2
#: (OR 5.6, 95 % CI 3.9-8.1).
PAPER_OR_BACKGROUND: float = 5.6
#: Odds ratio per log10 pixel. Source: Jung et al. 2015, Sec. 3.2.2 (OR 74.5, CI 48.9-113.5).
PAPER_OR_PER_LOG10_PX: float = 74.5
#: 50 % threshold of the cluttered condition, pixels. Source: Jung et al. 2015, Sec. 3.2.2 (8,695).
PAPER_X50_CLUTTERED_PX: float = 8695.0


def _stable_seed(*parts: object) -> int:
    """Return a seed from strings/ints, the same on every run and platform (not ``hash()``)."""
    h = hashlib.sha256("\x1f".join(map(str, parts)).encode()).digest()
    return int.from_bytes(h[:8], "little")


@dataclass(frozen=True)
class LogisticParams(AnswerParams):
    """Parameters of the ``logistic`` observer (see the module docstring for the model).

    The answer parameters (``lapse``, ``p_use``, ``p_shape``, ``median_rt_s``) are those of
    :class:`~experiment.observers.base.AnswerParams`, with the notes below.

    Parameters
    ----------
    or_background : float > 0
        Odds ratio de-cluttered vs cluttered (paper: 5.6).
    or_per_log10_px : float > 1
        Odds ratio per log10 pixel (paper: 74.5).
    x50_cluttered_px : float > 0
        Cluttered 50 % point for an average subject and object, pixels (paper: 8,695).
    subject_sd : float >= 0
        SD of the subject effect u, logit units. Ours (the paper's Fig. 9 spreads thresholds by
        well under a factor 2; 0.3 logit is a factor 1.2 in pixels at slope ln 74.5 / log10).
    object_sd : float >= 0
        SD of the object effects v, logit units. Ours (Fig. S3 spans about +-2 log odds).
    lapse : float in [0, 0.5)
        Probability of failing a trial that would have been recognised. Ours, and 0 by default
        on purpose: the paper's logistic regression has no lapse term, and in our simulations
        (10 subjects x 320 trials) a lapse of 0.01 already pulls its fitted OR per log10 px from
        74.5 to about 54 and 0.02 to about 45. With 0, ``confocal analyze`` recovers the paper's
        values; set it > 0 to study that bias.
    p_wrong : float in [0, 1]
        Share of unrecognised answers that name another object. Ours.
    p_shape : float in [0, 1]
        Share of the remaining unrecognised answers (after ``p_wrong``) that describe shape.
    population_seed : int
        Seed of the subject and object effects (shared by all simulated subjects).
    """

    or_background: float = PAPER_OR_BACKGROUND
    or_per_log10_px: float = PAPER_OR_PER_LOG10_PX
    x50_cluttered_px: float = PAPER_X50_CLUTTERED_PX
    subject_sd: float = 0.3
    object_sd: float = 1.0
    p_wrong: float = 0.3
    population_seed: int = 0

    def __post_init__(self) -> None:
        check_limits(
            self,
            {
                "or_background": "> 0",
                "or_per_log10_px": "> 1",
                "x50_cluttered_px": "> 0",
            },
        )
        super().__post_init__()

    @property
    def intercept(self) -> float:
        """Logit intercept b0 (log10 pixel axis), from ``x50_cluttered_px``."""
        return -math.log(self.or_per_log10_px) * math.log10(self.x50_cluttered_px)

    @property
    def x50_decluttered_px(self) -> float:
        """De-cluttered 50 % point for an average subject and object, pixels (no lapse)."""
        shift = math.log(self.or_background) / math.log(self.or_per_log10_px)
        return 10 ** (math.log10(self.x50_cluttered_px) - shift)


class LogisticResponder(SimulatedObserver):
    """The ``logistic`` observer of a session (a :class:`~experiment.interfaces.Responder`).

    The model is :class:`analysis.simulate.LogisticObserver` (the one logistic observer, which
    also simulates whole trial tables); this class draws its subject and object effects from
    ``population_seed`` and answers trials with that model's probabilities.

    Parameters
    ----------
    stimset : StimulusSet
        For object names and uses (the answer text).
    subject : str
        Subject code; with ``params.population_seed`` it fixes the subject effect.
    rng : numpy.random.Generator, int or None
        Trial-level randomness.
    params : LogisticParams, optional
    """

    name = "logistic"
    model = "the paper's fitted logistic model with subject and object effects"
    params_class = LogisticParams

    def _prepare(self) -> None:
        from analysis.simulate import LogisticObserver  # pandas and scipy: only when used

        p = self.params
        self._logistic = LogisticObserver.from_x50(
            p.x50_cluttered_px,
            background_or=p.or_background,
            log10_pixels_or=p.or_per_log10_px,
            subject_sd=p.subject_sd,
            object_sd=p.object_sd,
            lapse=p.lapse,
        )
        self.subject_effect = float(
            np.random.default_rng(_stable_seed(p.population_seed, "subject", self.subject)).normal(
                0.0, p.subject_sd
            )
        )
        self.object_effects = {
            oid: float(
                np.random.default_rng(_stable_seed(p.population_seed, "object", oid)).normal(
                    0.0, p.object_sd
                )
            )
            for oid in self.stimset.objects
        }

    def p_recognized(self, trial: Any) -> float:
        """Return P(recognised) for a trial (condition, pixels, object), lapse included."""
        if trial.condition in PHOTO_CONDITIONS:
            return 1.0 - self.params.lapse
        return float(
            self._logistic.p_recognized(
                trial.pixels,
                trial.condition == "decluttered",
                self.subject_effect,
                self.object_effects.get(trial.object, 0.0),
            )
        )

    def respond(self, trial: Any, image: np.ndarray) -> Answer:
        """Draw recognised or not, then an answer text and score consistent with it."""
        p = self.params
        ok = bool(self.rng.random() < self.p_recognized(trial))
        guess = None
        if not ok and self.rng.random() < p.p_wrong:
            others = [o for o in self.stimset.objects if o != trial.object]
            if others:
                guess = others[int(self.rng.integers(len(others)))]
        rt = response_time_s(self.rng, p.median_rt_s)
        wrong = None if guess is None else self.stimset.objects[guess].name
        return self._answer(trial, rt, recognized=ok, wrong=wrong, p_use=p.p_use, p_shape=p.p_shape)

    def _provenance(self) -> dict[str, Any]:
        return {
            "knowledge": {
                "source": "Jung et al. 2015, Sec. 3.2.2 (odds ratios and cluttered threshold); "
                "it does not look at the images"
            },
        }


@dataclass(frozen=True)
class TemplateParams(AnswerParams):
    """Parameters of the ``model`` (template-matching) observer. All are ours, not the paper's.

    The answer parameters (``lapse``, ``p_use``, ``p_shape``, ``median_rt_s``) are those of
    :class:`~experiment.observers.base.AnswerParams`; ``lapse`` defaults to 0.02 here.

    Every image (stimulus and templates) is first mapped onto a fixed "retinal" grid, because
    every level is shown at the same size on screen (14.6 x 9.7 cm): smaller images are enlarged
    by pixel replication, larger ones averaged over windows. It is then blurred (optics), and
    standardised to zero mean and unit SD (contrast gain control: thin full-resolution edges and
    fat compressed cells carry the same contrast energy). Gaussian noise is added to the
    stimulus, its Pearson correlation with each candidate template computed, and the best match
    answered when it stands out from the other candidates by ``criterion_z`` SDs.

    Parameters
    ----------
    retina_shape_px : (rows, cols)
        The observer's sampling grid. (164, 246) is half the 327x492 working size: about
        2.5 arcmin per sample for the paper's 10.4 deg wide image, near a normally sighted
        subject's acuity, so the eight levels stay distinguishable up to the top ones (a coarser
        grid averages every level above ~8,000 px down to the same picture).
    blur_sd_px : float >= 0
        SD of the Gaussian optical blur, grid samples.
    pixel_noise_sd : float >= 0
        SD of the internal noise per grid sample, in units of the standardised image's SD.
    template_level : int in 1..8, or None
        Level of the de-cluttered templates the observer compares the stimulus with: its memory
        of what each object looks like. 8 (default): the full-resolution edge image, so a
        coarse stimulus must be recognised from its blocky cells against the object's real
        shape, as a person must. None: the template at the stimulus' own level, which makes a
        de-cluttered stimulus match its own template pixel for pixel (an ideal observer that
        knows every compressed image; far better than people at low resolution).
        With the defaults, on the 20-object synthetic set of ``confocal demo`` (3 draws per
        stimulus, seed 1) recognition rose from 7 % (cluttered) and 13 % (de-cluttered) at
        12x8 to 82 % and 100 % at full resolution, de-cluttered above cluttered at every level
        (measured when these defaults were chosen; the demo reports what it measures).
    criterion_z : float
        The best correlation must exceed the mean of the other candidates' correlations by this
        many of their SDs for the observer to answer; otherwise it passes (or describes a
        shape).
    """

    retina_shape_px: tuple[int, int] = (164, 246)
    blur_sd_px: float = 1.5
    pixel_noise_sd: float = 16.0
    template_level: int | None = 8
    criterion_z: float = 3.0
    lapse: float = 0.02

    def __post_init__(self) -> None:
        r = self.retina_shape_px
        if not (isinstance(r, tuple) and len(r) == 2 and all(int(v) >= 2 for v in r)):
            raise ValueError(f"retina_shape_px must be (rows, cols) >= 2, got {r!r}")
        tl = self.template_level
        if tl is not None and (isinstance(tl, bool) or not isinstance(tl, int) or tl < 1):
            raise ValueError(f"template_level must be a level >= 1 or None, got {tl!r}")
        check_limits(self, {"blur_sd_px": ">= 0", "pixel_noise_sd": ">= 0"})
        super().__post_init__()


def to_retina(image: np.ndarray, shape_px: tuple[int, int], blur_sd_px: float) -> np.ndarray:
    """Map an image onto the observer's grid, blur it and standardise it (zero mean, unit SD).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), bool or float in [0, 1]
    shape_px : (rows, cols)
        The grid.
    blur_sd_px : float
        Gaussian blur SD, grid samples.

    Returns
    -------
    ndarray of shape ``shape_px``, float64
    """
    from scipy.ndimage import gaussian_filter

    from stimuli.compress import block_mean

    a = np.asarray(image, dtype=np.float32)
    rows, cols = shape_px
    f = int(np.ceil(max(rows / a.shape[0], cols / a.shape[1])))
    if f > 1:
        a = np.repeat(np.repeat(a, f, axis=0), f, axis=1)
    g = block_mean(a, (rows, cols)).astype(np.float64)
    if blur_sd_px > 0:
        g = gaussian_filter(g, blur_sd_px)
    sd = g.std()
    return (g - g.mean()) / (sd if sd > 0 else 1.0)


class TemplateObserver(SimulatedObserver):
    """The ``model`` simulated observer: noisy template matching on the shown image.

    Parameters
    ----------
    stimset : StimulusSet
        Supplies the candidate templates (every object of the same role).
    subject : str
        Unused by the model except in the rater name (kept for a uniform constructor).
    rng : numpy.random.Generator, int or None
    params : TemplateParams, optional
    """

    name = "model"
    model = "noisy template matching (pixel correlation)"
    params_class = TemplateParams

    def _prepare(self) -> None:
        self._cache: dict[tuple[str, str, int], tuple[list[str], np.ndarray]] = {}

    def _retina(self, image: np.ndarray) -> np.ndarray:
        p = self.params
        image = np.asarray(image)
        if image.ndim == 3:  # a colour training photo: its luminance (Rec. 709, as load_gray)
            image = (image[..., :3] @ np.array([0.2125, 0.7154, 0.0721], np.float32)).astype(
                np.float32
            )
        return to_retina(image, p.retina_shape_px, p.blur_sd_px).ravel()

    def _templates(self, role: str, condition: str, level: int) -> tuple[list[str], np.ndarray]:
        tcond = "photo" if condition in PHOTO_CONDITIONS else "decluttered"
        if tcond == "decluttered" and self.params.template_level is not None:
            level = self.params.template_level
        key = (role, tcond, level)
        if key not in self._cache:
            ids, rows = [], []
            for oid, info in self.stimset.objects.items():
                if info.role != role:
                    continue
                ids.append(oid)
                rows.append(
                    self._retina(self.stimset.load_image(self.stimset.get(oid, tcond, level)))
                )
            t = np.vstack(rows)
            t = t - t.mean(axis=1, keepdims=True)
            norms = np.sqrt(np.sum(t * t, axis=1, keepdims=True))
            self._cache[key] = (ids, t / np.where(norms > 0, norms, 1.0))
        return self._cache[key]

    def correlations(self, trial: Any, image: np.ndarray) -> tuple[list[str], np.ndarray]:
        """Return the candidate ids and the correlations of the noisy image with each template."""
        p = self.params
        role = self.stimset.objects[trial.object].role
        ids, t = self._templates(role, trial.condition, trial.level)
        x = self._retina(image)
        if p.pixel_noise_sd > 0:
            x = x + self.rng.normal(0.0, p.pixel_noise_sd, x.shape)
        x = x - x.mean()
        # element-wise sums, not BLAS: a multithreaded BLAS call per trial on a busy machine
        # costs far more than these 10^4-element products
        n = float(np.sqrt(np.sum(x * x)))
        return ids, np.sum(t * x, axis=1) / (n if n > 0 else 1.0)

    def _provenance(self) -> dict[str, Any]:
        lv = self.params.template_level
        return {
            "knowledge": {
                "source": f"the test stimulus set itself ({self.stimset.root}): its de-cluttered "
                + ("images at each stimulus' own level" if lv is None else f"level-{lv} images")
                + "; it knows the test objects' own pictures",
                "manifest_sha256": self.stimset.manifest_sha256,
            },
        }

    def respond(self, trial: Any, image: np.ndarray) -> Answer:
        """Answer the best-matching object, or pass when no candidate stands out."""
        p = self.params
        rt = response_time_s(self.rng, p.median_rt_s)
        ids, r = self.correlations(trial, image)
        if self.rng.random() < p.lapse:
            return self._answer(trial, rt, recognized=False)
        best = int(np.argmax(r))
        others = np.delete(r, best)
        spread = float(others.std()) if others.size > 1 else 0.0
        gap = float(r[best] - others.mean()) if others.size else float("inf")
        z = gap / spread if spread > 0 else (float("inf") if gap > 0 else 0.0)
        if z < p.criterion_z:
            return self._answer(trial, rt, recognized=False, p_shape=p.p_shape)
        if ids[best] == trial.object:
            return self._answer(trial, rt, recognized=True, p_use=p.p_use)
        return self._answer(trial, rt, recognized=False, wrong=self.stimset.objects[ids[best]].name)


#: Simulated observers by name: a factory ``(stimset, subject, *, rng, **params) -> Responder``.
OBSERVERS: dict[str, Callable[..., Any]] = {}


def _register(name: str, cls: type, params_cls: type) -> None:
    def factory(stimset: StimulusSet, subject: str, *, rng=None, **params: Any) -> Any:
        known = {f.name for f in fields(params_cls)}
        bad = sorted(set(params) - known)
        if bad:
            raise ValueError(
                f"unknown parameter {bad[0]!r} for observer {name!r} "
                f"(expected one of {', '.join(sorted(known))})"
            )
        return cls(stimset, subject, rng=rng, params=params_cls(**params))

    factory.__doc__ = f"Make a {cls.__name__} ({name!r})."
    OBSERVERS[name] = factory


_register("logistic", LogisticResponder, LogisticParams)
_register("model", TemplateObserver, TemplateParams)
_register("exemplar", ExemplarObserver, ExemplarParams)
_register("calibrated", CalibratedObserver, CalibratedParams)


def describe_observer(responder: Any) -> dict[str, Any]:
    """Return a simulated observer's description for the trial log (JSON-able).

    Uses the observer's own ``describe()`` (name, parameters, the data its knowledge came
    from) where it has one, else its name and dataclass parameters.
    """
    if hasattr(responder, "describe"):
        return responder.describe()
    params = getattr(responder, "params", None)
    return {
        "observer": getattr(responder, "name", type(responder).__name__),
        "simulated": True,
        "params": asdict(params) if is_dataclass(params) else None,
    }


def make_observer(
    name: str,
    stimset: StimulusSet,
    subject: str,
    *,
    rng: np.random.Generator | int | None = None,
    **params: Any,
) -> Any:
    """Return the simulated observer registered as ``name``.

    Parameters
    ----------
    name : {'calibrated', 'exemplar', 'logistic', 'model'}
    stimset : StimulusSet
    subject : str
    rng : numpy.random.Generator, int or None
    **params
        Fields of :class:`CalibratedParams`, :class:`ExemplarParams`, :class:`LogisticParams`
        or :class:`TemplateParams`.

    Raises
    ------
    ValueError
        Unknown observer name or parameter.
    """
    if name not in OBSERVERS:
        raise ValueError(f"observer must be one of {', '.join(sorted(OBSERVERS))}, got {name!r}")
    return OBSERVERS[name](stimset, subject, rng=rng, **params)
