"""Optional adapter: an implant view rendered by pulse2percept's models, for comparison.

``pip install 'active-confocal[p2p]'`` installs pulse2percept (Beyeler et al. 2017). The viewer's
own phosphenes (:func:`stimuli.implants.render_phosphenes`) are round Gaussians or discs
on the electrode grid; pulse2percept's *scoreboard* model is the same idea in retinal
coordinates, and its *axon-map* model elongates each phosphene along the retinal nerve-fibre
bundles (Beyeler et al. 2019), which is what Argus II users report. This module turns the
electrode values of a layout with a retinal pitch into such a percept image. pulse2percept is
imported here only, when called (house style H13).

References
----------
Beyeler, M., Boynton, G. M., Fine, I., & Rokem, A. (2017). pulse2percept: A Python-based
simulation framework for bionic vision. Proc. 16th Python in Science Conf., 81-88.
Beyeler, M., Nanduri, D., Weiland, J. D., Rokem, A., Boynton, G. M., & Fine, I. (2019). A model
of ganglion axon pathways accounts for percepts elicited by retinal implants. Sci. Rep. 9, 9199.
"""

from __future__ import annotations

import functools

import numpy as np

from experiment.errors import ConfocalError
from stimuli.implants import ImplantLayout

__all__ = ["P2P_MODELS", "P2P_RHO_UM", "P2P_LAMBDA_UM", "p2p_percept", "p2p_unavailable"]

#: pulse2percept models the adapter can use.
P2P_MODELS: tuple[str, ...] = ("scoreboard", "axonmap")

#: Spatial decay of the current, micrometres (ours: 100 um, within the 50-400 um that
#: Beyeler et al. 2019, Table 1, fitted for Argus II users).
P2P_RHO_UM: float = 100.0

#: Axon-map elongation along the nerve fibres, micrometres (ours: pulse2percept's default).
P2P_LAMBDA_UM: float = 500.0


def p2p_unavailable(layout: ImplantLayout) -> str:
    """Return why pulse2percept cannot draw ``layout`` ('' when it can)."""
    if layout.pitch_um is None:
        return f"{layout.label} has no retinal pitch_um (pulse2percept models retinas)"
    try:
        import pulse2percept  # noqa: F401
    except ImportError:
        return "pulse2percept is not installed (pip install 'active-confocal[p2p]')"
    return ""


@functools.lru_cache(maxsize=8)
def _built_model(layout: ImplantLayout, model: str, rho_um: float, lambda_um: float):
    # Building a model (the axon map above all: seconds) is done once per layout and model;
    # predicting a percept from it is then fast enough for the live view.
    from pulse2percept.implants import ElectrodeGrid
    from pulse2percept.implants.retina import RetinalImplant
    from pulse2percept.models.retina import AxonMapModel, ScoreboardModel

    # pulse2percept's rot is in degrees, counter-clockwise on the retinal surface
    implant = RetinalImplant(
        ElectrodeGrid(layout.shape, layout.pitch_um, rot=float(layout.rotation_deg))
    )
    sy, sx = layout.spacing_deg
    half_w, half_h = layout.fov_width_deg / 2 + sx, layout.fov_height_deg / 2 + sy
    kw = dict(rho=rho_um, xrange=(-half_w, half_w), yrange=(-half_h, half_h), step=min(sx, sy) / 8)
    if model == "scoreboard":
        return ScoreboardModel(implant, **kw).build()
    import tempfile

    # pulse2percept caches its axon bundles in a file, by default in the current folder;
    # keep it in a temporary folder instead (nothing left behind)
    with tempfile.TemporaryDirectory(prefix="confocal-p2p-") as tmp:
        return AxonMapModel(
            implant, lam=lambda_um, axon_pickle=f"{tmp}/axons.pickle", verbose=False, **kw
        ).build()


def p2p_percept(
    cells: np.ndarray,
    layout: ImplantLayout,
    *,
    model: str = "scoreboard",
    rho_um: float = P2P_RHO_UM,
    lambda_um: float = P2P_LAMBDA_UM,
) -> np.ndarray:
    """Render electrode values through a pulse2percept model.

    Parameters
    ----------
    cells : ndarray of shape (layout.rows, layout.cols), bool or float in [0, 1]
        Electrode values (row 0 = top of the visual field).
    layout : ImplantLayout
        Needs ``pitch_um`` (a retinal implant); its ``rotation_deg`` turns the grid. The built
        model is cached per layout, model and parameters (the live viewer calls this per
        frame).
    model : {'scoreboard', 'axonmap'}
    rho_um, lambda_um : float > 0
        Current spread and (axon map) elongation, micrometres.

    Returns
    -------
    ndarray of shape (rows, cols), float32 in [0, 1]
        The percept over the implant's field of view plus one spacing on each side, sampled at
        an eighth of the spacing, scaled so its brightest point is 1 (all zeros stay zeros).

    Raises
    ------
    ConfocalError
        pulse2percept not installed, an unknown model, or a layout without a retinal pitch.
    """
    if model not in P2P_MODELS:
        raise ConfocalError(f"p2p model must be one of {P2P_MODELS}, got {model!r}")
    if layout.pitch_um is None:
        raise ConfocalError(
            f"implant {layout.name!r} has no retinal pitch_um: pulse2percept models retinas"
        )
    v = np.asarray(cells, dtype=np.float64)
    if v.shape != layout.shape:
        raise ConfocalError(f"cells must have the implant's shape {layout.shape}, got {v.shape}")
    try:
        import pulse2percept  # noqa: F401
    except ImportError:
        raise ConfocalError(
            "pulse2percept is not installed: pip install 'active-confocal[p2p]'"
        ) from None
    m = _built_model(layout, model, float(rho_um), float(lambda_um))
    if not v.any():
        p = m.predict_percept(np.full(v.size, 1e-9)).data[..., 0]
        return np.zeros(p.shape, np.float32)
    p = np.asarray(m.predict_percept(v.ravel()).data[..., 0], dtype=np.float64)
    top = float(p.max())
    return np.clip(p / top if top > 0 else p, 0.0, 1.0).astype(np.float32)
