"""Implant layouts as data: electrode grid, field of view, phosphene look.

A layout is a TOML file in ``protocols/implants/`` (shipped like the protocols; installed under
``<prefix>/share/confocal/protocols/implants``) or any ``.toml`` file a user writes. Fields:

=================  ==========================================================================
field              meaning
=================  ==========================================================================
label              display name (str)
kind               ``epiretinal``, ``subretinal``, ``suprachoroidal``, ``cortical``,
                   ``tactile`` or ``other``
rows, cols         electrode grid (int >= 1)
pitch_um           centre-to-centre spacing on the tissue, micrometres (optional, > 0)
fov_width_deg      field of view of the grid, degrees of visual angle (> 0, <= 180)
fov_height_deg
phosphene_shape    ``gaussian`` or ``disc``
phosphene_size     phosphene diameter (disc) or FWHM (gaussian) as a fraction of the spacing
dropout            fraction of electrodes that never light, in [0, 1)
levels             brightness levels of a phosphene (int >= 2; 2 = on/off)
seed               seed of the dropout pattern and of the brightness variation (int)
rotation_deg       rotation of the array on the retina, degrees counter-clockwise in the visual
                   field, in [-180, 180] (optional, default 0)
brightness_sd      per-electrode brightness variation: each electrode's gain is
                   ``clip(1 + brightness_sd * z, 0, 2)``, ``z`` standard normal from ``seed``,
                   in [0, 1] (optional, default 0: all equal)
dead_electrodes    electrodes that never light, ``[[row, col], ...]`` (0-based, row 0 at the
                   top), on top of the random ``dropout`` (optional, default none)
source             citation (str, optional)
=================  ==========================================================================

The defaults of the optional fields draw what a layout without them drew: an upright array of
equal phosphenes with only the seeded dropout.

Every field is checked when the file is read; a bad one ends with one line naming the file and
the field (:class:`ImplantError`, exit status 2), as protocols do.

:func:`to_implant_grid` resamples a stimulus to an implant's electrode grid, the one step that
``confocal stimuli build --implant``, ``confocal present --implant`` and a protocol's
``[display] implant`` share. :func:`render_phosphenes` is the numpy reference for the phosphene
drawing that the GPU viewer (``experiment.viewer.gpu``) and the presenter do in shaders.

The layouts live in ``stimuli`` (not ``experiment``) so that stimulus building can use them
without importing the experiment engine or OpenGL (house style H1).
"""

from __future__ import annotations

import functools
import math
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from stimuli import jung2015
from stimuli.compress import compress, compress_grey
from stimuli.datadirs import PROTOCOLS_DIR
from stimuli.errors import InputError
from stimuli.io import check_gray

__all__ = [
    "IMPLANTS_DIR",
    "IMPLANT_KINDS",
    "RETINA_UM_PER_DEG",
    "ImplantError",
    "ImplantLayout",
    "load_implant",
    "implant_names",
    "render_phosphenes",
    "to_implant_grid",
]

#: Folder of the shipped implant layouts.
IMPLANTS_DIR: Path = PROTOCOLS_DIR / "implants"

#: Allowed values of ``kind``.
IMPLANT_KINDS: tuple[str, ...] = (
    "epiretinal",
    "subretinal",
    "suprachoroidal",
    "cortical",
    "tactile",
    "other",
)

#: Micrometres of human retina per degree of visual angle near the fovea.
#: Source: Drasdo & Fowler (1974), Br. J. Ophthalmol. 58:709 (0.288 mm/deg); used to check the
#: shipped retinal layouts' fields of view against their pitch.
RETINA_UM_PER_DEG: float = 288.0

_FIELDS = (
    "label",
    "kind",
    "rows",
    "cols",
    "pitch_um",
    "fov_width_deg",
    "fov_height_deg",
    "phosphene_shape",
    "phosphene_size",
    "dropout",
    "levels",
    "seed",
    "rotation_deg",
    "brightness_sd",
    "dead_electrodes",
    "source",
)


class ImplantError(InputError):
    """An implant layout is missing or invalid, or does not fit a stimulus (one line, exit 2)."""


@dataclass(frozen=True)
class ImplantLayout:
    """An implant's electrode grid, field of view and phosphene look.

    Parameters
    ----------
    name : str
        Short name (the file stem: ``argus2``).
    label : str
    kind : str
        One of :data:`IMPLANT_KINDS`.
    rows, cols : int >= 1
        Electrode grid.
    fov_width_deg, fov_height_deg : float in (0, 180]
        Field of view of the grid, degrees.
    pitch_um : float > 0 or None
        Spacing on the tissue, micrometres.
    phosphene_shape : {'gaussian', 'disc'}
    phosphene_size : float > 0
        Diameter (disc) or FWHM (gaussian), fraction of the spacing.
    dropout : float in [0, 1)
        Fraction of dead electrodes.
    levels : int >= 2
        Brightness levels.
    seed : int
        Seed of the dropout pattern and of the brightness variation.
    rotation_deg : float in [-180, 180]
        Rotation of the array, degrees counter-clockwise in the visual field.
    brightness_sd : float in [0, 1]
        Standard deviation of the per-electrode gain around 1 (dimensionless).
    dead_electrodes : tuple of (row, col)
        Electrodes that never light, besides the random dropout.
    source : str
        Citation.
    """

    name: str
    label: str
    kind: str
    rows: int
    cols: int
    fov_width_deg: float
    fov_height_deg: float
    pitch_um: float | None = None
    phosphene_shape: str = "gaussian"
    phosphene_size: float = 0.8
    dropout: float = 0.0
    levels: int = 2
    seed: int = 0
    rotation_deg: float = 0.0
    brightness_sd: float = 0.0
    dead_electrodes: tuple[tuple[int, int], ...] = ()
    source: str = ""

    def __post_init__(self) -> None:
        dead = self.dead_electrodes
        if isinstance(dead, list | tuple) and all(isinstance(e, list | tuple) for e in dead):
            object.__setattr__(self, "dead_electrodes", tuple(tuple(e) for e in dead))
        for name in _FIELDS:
            getattr(self, f"_check_{name}", lambda: None)()

    def _fail(self, field: str, expected: str) -> None:
        raise ImplantError(
            f"implant {self.name!r}: field {field!r} must be {expected}, "
            f"got {getattr(self, field)!r}"
        )

    def _int(self, field: str, lo: int) -> None:
        v = getattr(self, field)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            self._fail(field, f"an integer >= {lo}")

    def _check_label(self) -> None:
        if not isinstance(self.label, str) or not self.label.strip():
            self._fail("label", "a non-empty string")

    def _check_kind(self) -> None:
        if self.kind not in IMPLANT_KINDS:
            self._fail("kind", f"one of {', '.join(IMPLANT_KINDS)}")

    def _check_rows(self) -> None:
        self._int("rows", 1)

    def _check_cols(self) -> None:
        self._int("cols", 1)

    def _positive(self, field: str, hi: float = math.inf) -> None:
        v = getattr(self, field)
        if isinstance(v, bool) or not isinstance(v, int | float) or not 0 < v <= hi:
            self._fail(field, f"a number in (0, {hi:g}]")

    def _check_pitch_um(self) -> None:
        if self.pitch_um is not None:
            self._positive("pitch_um")

    def _check_fov_width_deg(self) -> None:
        self._positive("fov_width_deg", 180.0)

    def _check_fov_height_deg(self) -> None:
        self._positive("fov_height_deg", 180.0)

    def _check_phosphene_shape(self) -> None:
        if self.phosphene_shape not in ("gaussian", "disc"):
            self._fail("phosphene_shape", "'gaussian' or 'disc'")

    def _check_phosphene_size(self) -> None:
        self._positive("phosphene_size", 4.0)

    def _check_dropout(self) -> None:
        v = self.dropout
        if isinstance(v, bool) or not isinstance(v, int | float) or not 0 <= v < 1:
            self._fail("dropout", "a number in [0, 1)")

    def _check_levels(self) -> None:
        self._int("levels", 2)

    def _check_seed(self) -> None:
        self._int("seed", 0)

    def _check_rotation_deg(self) -> None:
        v = self.rotation_deg
        if isinstance(v, bool) or not isinstance(v, int | float) or not -180 <= v <= 180:
            self._fail("rotation_deg", "a number of degrees in [-180, 180]")

    def _check_brightness_sd(self) -> None:
        v = self.brightness_sd
        if isinstance(v, bool) or not isinstance(v, int | float) or not 0 <= v <= 1:
            self._fail("brightness_sd", "a number in [0, 1]")

    def _check_dead_electrodes(self) -> None:
        want = f"a list of [row, col] pairs inside the {self.rows}x{self.cols} grid"
        if not isinstance(self.dead_electrodes, tuple):
            self._fail("dead_electrodes", want)
        for e in self.dead_electrodes:
            ok = isinstance(e, tuple) and len(e) == 2
            ok = ok and all(isinstance(v, int) and not isinstance(v, bool) for v in e)
            if not ok or not (0 <= e[0] < self.rows and 0 <= e[1] < self.cols):
                raise ImplantError(
                    f"implant {self.name!r}: field 'dead_electrodes' must be {want}, "
                    f"got {list(e) if isinstance(e, tuple) else e!r}"
                )

    def _check_source(self) -> None:
        if not isinstance(self.source, str):
            self._fail("source", "a string")

    @property
    def shape(self) -> tuple[int, int]:
        """Electrode grid ``(rows, cols)``."""
        return (self.rows, self.cols)

    @property
    def n_electrodes(self) -> int:
        """Number of grid sites, ``rows * cols``."""
        return self.rows * self.cols

    @property
    def spacing_deg(self) -> tuple[float, float]:
        """Phosphene spacing ``(vertical, horizontal)``, degrees."""
        return (self.fov_height_deg / self.rows, self.fov_width_deg / self.cols)

    def alive_mask(self) -> np.ndarray:
        """Return the bool ``(rows, cols)`` mask of electrodes that light.

        Dead: the seeded random ``dropout`` and the listed ``dead_electrodes``.
        """
        rng = np.random.default_rng(self.seed)
        alive = rng.random(self.shape) >= self.dropout
        for r, c in self.dead_electrodes:
            alive[r, c] = False
        return alive

    def electrode_gain(self) -> np.ndarray:
        """Return each electrode's brightness factor, float32 ``(rows, cols)`` in [0, 2].

        0 for a dead electrode (:meth:`alive_mask`), else ``clip(1 + brightness_sd * z, 0, 2)``
        with ``z`` standard normal drawn after the dropout from the same seeded generator (so
        the dropout pattern does not depend on ``brightness_sd``). All ones by default.
        """
        rng = np.random.default_rng(self.seed)
        rng.random(self.shape)  # the dropout draw of alive_mask: keep the streams aligned
        gain = np.ones(self.shape, np.float32)
        if self.brightness_sd > 0:
            z = rng.standard_normal(self.shape)
            gain = np.clip(1.0 + self.brightness_sd * z, 0.0, 2.0).astype(np.float32)
        return gain * self.alive_mask()

    def to_dict(self) -> dict[str, Any]:
        """Return the layout as a plain dict (the TOML fields plus ``name``)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, name: str | None = None) -> ImplantLayout:
        """Build a layout from TOML fields; unknown or missing fields are one-line errors."""
        name = str(data.get("name", name or "custom"))
        unknown = sorted(set(data) - set(_FIELDS) - {"name"})
        if unknown:
            raise ImplantError(
                f"implant {name!r}: unknown field {unknown[0]!r} (expected: {', '.join(_FIELDS)})"
            )
        for need in ("label", "kind", "rows", "cols", "fov_width_deg", "fov_height_deg"):
            if need not in data:
                raise ImplantError(f"implant {name!r}: field {need!r} is missing")
        kw = {k: v for k, v in data.items() if k != "name"}
        return cls(name=name, **kw)

    def with_(self, **changes: Any) -> ImplantLayout:
        """Return a copy with some fields changed (checked again)."""
        return ImplantLayout.from_dict({**self.to_dict(), **changes})


def implant_names() -> list[str]:
    """Return the names of the shipped layouts, sorted."""
    if not IMPLANTS_DIR.is_dir():
        return []
    return sorted(p.stem for p in IMPLANTS_DIR.glob("*.toml"))


def load_implant(name_or_path: str | Path) -> ImplantLayout:
    """Load a shipped layout by name (``argus2``) or a user's layout from a ``.toml`` file.

    Raises
    ------
    ImplantError
        Unknown name, unreadable file, TOML syntax error, or an invalid field.
    """
    if isinstance(name_or_path, ImplantLayout):
        return name_or_path
    text = str(name_or_path)
    path = Path(text)
    if path.suffix.lower() != ".toml":
        path = IMPLANTS_DIR / f"{text}.toml"
        if not path.is_file():
            raise ImplantError(
                f"unknown implant {text!r} (shipped: {', '.join(implant_names())}; "
                "or give a .toml file)"
            )
    if not path.is_file():
        raise ImplantError(f"{path}: implant layout not found")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ImplantError(f"{path}: cannot read ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ImplantError(f"{path}: not valid TOML ({exc})") from None
    except RecursionError:  # tomllib parses nested tables and arrays recursively
        raise ImplantError(f"{path}: not valid TOML (tables or arrays nested too deeply)") from None
    try:
        return ImplantLayout.from_dict(data, name=path.stem)
    except ImplantError as exc:
        raise ImplantError(f"{path}: {exc}") from None
    except TypeError as exc:  # a field of the wrong TOML type reaching the dataclass
        raise ImplantError(f"{path}: {exc}") from None


def render_phosphenes(
    cells: np.ndarray,
    shape_px: tuple[int, int],
    *,
    shape: str = "gaussian",
    size: float = 0.8,
    alive: np.ndarray | None = None,
    gain: np.ndarray | None = None,
    rotation_deg: float = 0.0,
) -> np.ndarray:
    """Draw a grid of electrode values as phosphenes filling a ``shape_px`` image (reference).

    Each electrode ``(i, j)`` sits at the centre of its cell, ``((i + 0.5) ph, (j + 0.5) pw)``
    with pitch ``ph = rows_px / rows``, ``pw = cols_px / cols``. A pixel centre sums the profiles
    of the 3x3 electrodes around its own cell, clipped to 1: a Gaussian of FWHM ``size *
    min(ph, pw)``, or a disc of that diameter. A rotated array is drawn by turning each pixel
    centre back by ``rotation_deg`` about the image centre and drawing the upright array there
    (parts of the array turned outside the image are not drawn). This is what the shaders
    compute.

    Parameters
    ----------
    cells : ndarray of shape (rows, cols), bool or float in [0, 1]
    shape_px : (rows, cols)
        Size of the drawing, pixels.
    shape : {'gaussian', 'disc'}
    size : float > 0
        Diameter or FWHM, fraction of the spacing.
    alive : ndarray of shape (rows, cols), bool, optional
        Electrodes that light; dead ones stay dark.
    gain : ndarray of shape (rows, cols), float >= 0, optional
        Per-electrode brightness factor (:meth:`ImplantLayout.electrode_gain`).
    rotation_deg : float
        Rotation of the array, degrees counter-clockwise on the image.

    Returns
    -------
    ndarray of shape ``shape_px``, float32 in [0, 1]
    """
    v = np.asarray(cells, dtype=np.float32)
    if v.ndim != 2:
        raise ValueError(f"cells must be 2-D (rows, cols), got shape {v.shape}")
    if shape not in ("gaussian", "disc"):
        raise ValueError(f"shape must be 'gaussian' or 'disc', got {shape!r}")
    if alive is not None:
        v = v * np.asarray(alive, dtype=np.float32)
    if gain is not None:
        v = v * np.asarray(gain, dtype=np.float32)
    rows, cols = (int(s) for s in shape_px)
    geo = _phosphene_geometry(
        v.shape, (rows, cols), shape, float(size), float(rotation_deg) % 360.0
    )
    if geo[0] == "separable":
        from stimuli.rowthreads import one_blas_thread

        # OpenBLAS threads cost more than they save on these thin products (measured: 20 ms
        # instead of 3 ms for a 523x931 Argus II drawing on two busy cores)
        with one_blas_thread():
            total = (geo[1] @ v) @ geo[2]
    else:
        total = (geo[1] @ v.ravel()).reshape(rows, cols)
    return np.minimum(total, np.float32(1.0)).astype(np.float32)


@functools.lru_cache(maxsize=4)
def _phosphene_geometry(
    grid: tuple[int, int], shape_px: tuple[int, int], shape: str, size: float, rotation_deg: float
) -> tuple:
    # The drawing is linear in the electrode values, so its geometry is computed once per
    # (grid, image size, look) and each frame is a product: an upright Gaussian is separable,
    # exp(-(dy^2 + dx^2) / 2 s^2) = exp(-dy^2 / 2 s^2) exp(-dx^2 / 2 s^2), so the image is
    # A_rows @ cells @ A_cols with the 3x3-neighbourhood rule in the band of each matrix; a disc
    # or a rotated array is a sparse (pixels x electrodes) matrix. Summing in another order
    # than a per-pixel loop changes the result by float32 rounding only.
    n_r, n_c = grid
    rows, cols = shape_px
    ph, pw = np.float32(rows / n_r), np.float32(cols / n_c)
    d_size = np.float32(size) * min(ph, pw)
    sigma = d_size / np.float32(2.3548)
    y = np.arange(rows, dtype=np.float32)[:, None] + np.float32(0.5)
    x = np.arange(cols, dtype=np.float32)[None, :] + np.float32(0.5)
    if shape == "gaussian" and rotation_deg == 0.0:

        def band(pos: np.ndarray, pitch: np.float32, n: int) -> np.ndarray:
            k0 = np.floor(pos / pitch).astype(np.int64)  # (m, 1)
            k = np.arange(n)[None, :]
            d = pos - (k.astype(np.float32) + np.float32(0.5)) * pitch
            a = np.exp(-(d * d) / (np.float32(2.0) * sigma * sigma)).astype(np.float32)
            return np.where(np.abs(k - k0) <= 1, a, np.float32(0)).astype(np.float32)

        return ("separable", band(y, ph, n_r), np.ascontiguousarray(band(x.T, pw, n_c).T))
    from scipy.sparse import csr_matrix

    if rotation_deg != 0.0:
        th = math.radians(rotation_deg)
        cy, cx = np.float32(rows / 2), np.float32(cols / 2)
        c, s = np.float32(math.cos(th)), np.float32(math.sin(th))
        dy, dx = y - cy, x - cx
        # a pixel shows the point of the upright array turned back by the rotation
        # (counter-clockwise on the image, whose rows run downwards)
        x, y = cx + dx * c - dy * s, cy + dx * s + dy * c
    else:
        y, x = np.broadcast_arrays(y, x)
    r0 = np.floor(y / ph).astype(np.int64)
    c0 = np.floor(x / pw).astype(np.int64)
    pix = np.arange(rows * cols).reshape(rows, cols)
    idx_p, idx_e, wts = [], [], []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            r, cc = r0 + dr, c0 + dc
            dy = y - (r.astype(np.float32) + np.float32(0.5)) * ph
            dx = x - (cc.astype(np.float32) + np.float32(0.5)) * pw
            r2 = dy * dy + dx * dx
            if shape == "gaussian":
                w = np.exp(-r2 / (np.float32(2.0) * sigma * sigma)).astype(np.float32)
            else:
                w = (r2 <= np.float32(0.25) * d_size * d_size).astype(np.float32)
            ok = (r >= 0) & (r < n_r) & (cc >= 0) & (cc < n_c) & (w > 0)
            idx_p.append(pix[ok])
            idx_e.append((r * n_c + cc)[ok])
            wts.append(w[ok])
    m = csr_matrix(
        (np.concatenate(wts), (np.concatenate(idx_p), np.concatenate(idx_e))),
        shape=(rows * cols, n_r * n_c),
        dtype=np.float32,
    )
    return ("sparse", m)


def to_implant_grid(
    image: np.ndarray, layout: ImplantLayout, *, edge_ratio: float = jung2015.EDGE_RATIO
) -> np.ndarray:
    """Resample a stimulus to an implant's electrode grid, as the implant would show it.

    A binary (edge) stimulus is compressed by the paper's rule: an electrode is on when its
    window's edge fraction exceeds ``edge_ratio`` (:func:`stimuli.compress.compress`). A grey
    stimulus gets its window means quantised to the implant's ``levels``
    (:func:`stimuli.compress.compress_grey`, Fig. 2).

    Parameters
    ----------
    image : ndarray of shape (rows, cols), bool or float32 in [0, 1]
        The stimulus; at least as many rows and columns as the implant's grid.
    layout : ImplantLayout
    edge_ratio : float in [0, 1)
        Edge fraction above which an electrode is on (binary stimuli only; dimensionless).

    Returns
    -------
    ndarray of shape ``layout.shape``
        bool for a binary stimulus, float32 in [0, 1] at ``layout.levels`` levels for a grey one.

    Raises
    ------
    ImplantError
        The grid is finer than the stimulus (an implant cannot show more than it is given).
    InputError
        ``image`` is not 2-D, or a float image is outside [0, 1].

    References
    ----------
    Jung et al. (2015), Sec. 2.2 (compression by non-overlapping windows, edge ratio 1/13).

    Examples
    --------
    >>> lay = load_implant("argus2")
    >>> to_implant_grid(np.ones((60, 100), bool), lay).shape
    (6, 10)
    """
    if not isinstance(layout, ImplantLayout):
        raise TypeError(f"layout must be an ImplantLayout, got {type(layout).__name__}")
    a = np.asarray(image)
    if a.ndim != 2:
        raise InputError(f"image must be 2-D (rows, cols), got shape {a.shape}")
    if layout.rows > a.shape[0] or layout.cols > a.shape[1]:
        raise ImplantError(
            f"implant {layout.name!r}: its {layout.cols}x{layout.rows} grid is finer than the "
            f"{a.shape[1]}x{a.shape[0]} stimulus"
        )
    if a.dtype == bool:
        return compress(a, layout.shape, edge_ratio=edge_ratio)
    return compress_grey(check_gray(a), layout.shape, grey_levels=layout.levels)
