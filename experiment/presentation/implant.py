"""An implant layout as the subject's screen draws it: its grid as phosphenes.

``confocal present --implant`` and a protocol's ``[display] implant`` show a stimulus the same
way: resampled to the implant's electrode grid (:func:`stimuli.implants.to_implant_grid`) and
drawn as the implant's phosphenes at its field of view, with the :class:`PhospheneSpec` that
:func:`phosphene_spec` makes from the layout.
"""

from __future__ import annotations

from stimuli.implants import ImplantLayout

__all__ = ["phosphene_spec"]


def phosphene_spec(layout: ImplantLayout):
    """Return the presenter's ``PhospheneSpec`` for an implant layout.

    The phosphenes take the layout's shape, size, dropout and seed, and are spaced so that the
    grid spans the implant's horizontal field of view: ``fov_width_deg / cols`` degrees apart.

    Parameters
    ----------
    layout : stimuli.implants.ImplantLayout

    Returns
    -------
    experiment.presentation.frame.PhospheneSpec
    """
    from experiment.presentation.frame import PhospheneSpec

    if not isinstance(layout, ImplantLayout):
        raise TypeError(f"layout must be an ImplantLayout, got {type(layout).__name__}")
    return PhospheneSpec(
        kind=layout.phosphene_shape,
        size=layout.phosphene_size,
        dropout=layout.dropout,
        spacing_deg=layout.fov_width_deg / layout.cols,
        seed=layout.seed,
    )
