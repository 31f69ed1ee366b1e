"""Build a stimulus set from photo pairs (or light fields): Jung et al. 2015, Sec. 3.1.

The pipeline, per object
------------------------
1. Read the wide-DOF ("conventional") and narrow-DOF ("confocal") photos with
   :func:`stimuli.io.load_gray` (luminance, float32 in [0, 1], EXIF orientation applied). A
   light-field object gives the pair through ``stimuli.confocal.confocal_pair`` instead: its
   centre view is the cluttered image and the confocal image the de-cluttered one.
2. Zoom (optional, paper Sec. 4.1, Fig. 14): the ``crop`` box ``x,y,w,h`` of ``objects.csv`` is
   cut out at full resolution before anything else.
3. Centre-crop to the working aspect (492:327 by default) if needed, then an anti-aliased resize
   to the working size with ``skimage.transform.resize(..., anti_aliasing=True)``.
4. Sobel magnitude and threshold (:mod:`stimuli.declutter`): the per-object value of
   ``objects.csv``, else the global ``threshold``, else an automatic one at the working size:
   by default the pair's minimum edge retention (:func:`stimuli.retention.retention_threshold`,
   the method of ``confocal stimuli tune``), or Otsu / triangle on the narrow-DOF image
   (:func:`stimuli.declutter.auto_threshold`); the same value is applied to the wide-DOF
   image, as in the paper.
5. Edge ratio ``r``: given, or the mean edge-pixel fraction over the wide-DOF edge images of the
   set's main objects (the paper found 1/13 = 7.7 %).
6. Compression by non-overlapping windows 1, 2, 3, 5, 7, 13, 18, 40 (:mod:`stimuli.compress`);
   in grey mode the photos themselves are compressed to ``grey_levels`` levels (Fig. 2).
7. Implant views (optional): for each implant layout given, each condition's image at
   the working size (the edge image, i.e. the window-1 stimulus; in grey mode the grey photo)
   is resampled to the implant's electrode grid (:func:`stimuli.implants.to_implant_grid`, with
   the set's edge ratio) and drawn as its phosphenes (:func:`stimuli.implants.render_phosphenes`,
   :data:`IMPLANT_PX_PER_ELECTRODE` px per electrode), under ``implants/<name>/<object>/``.
   ``stimulus_set.json`` lists every file with its sha256 and the implant's whole layout.

The set is written into a temporary folder beside the output folder and renamed onto it at
the end, so the output folder is untouched by any error.

The modules, one per step
-------------------------
``params``         the command line's texts and the frozen :class:`BuildParams`
``plan``           every argument checked and resolved once into a :class:`BuildPlan`
``pairs``          the PAIRS input: object folders or CSV, source hashes (step 1)
``lightfield``     a light-field object's pair at its confocal plane (step 1)
``prepare``        zoom, aspect crop and resize to the working size (steps 2-3)
``edges``          threshold choice, de-cluttering and the set's edge ratio (steps 4-5)
``levels``         compression at every window (step 6)
``implant_views``  the stimuli as implants show them (step 7)
``write``          the PNGs, contact sheets, ``manifest.csv``, through a staging folder
``provenance``     object summaries, notes and ``stimulus_set.json``
``parallel``       one step over every object on a thread pool or on worker processes (or a
                   Dask cluster: :class:`stimuli.lfbatch.CapturePool`), with progress
``run``            :func:`build_stimulus_set`: the plan, then its steps in order (:func:`run_plan`);
                   each step returns a new frozen result, and nothing is read twice

The public names below are loaded when first used (``lazy_loader``), so that a command that
needs only ``params`` (``--threshold`` checks, ``--help``) does not import the whole pipeline.
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "edges": ["edge_fraction"],
        "implant_views": ["IMPLANT_PX_PER_ELECTRODE"],
        "levels": ["edge_ladder", "grey_ladder"],
        "pairs": ["PairSource", "PairsInput", "read_pairs"],
        "params": [
            "BuildParams",
            "THRESHOLD_METHODS",
            "min_photo_shape_px",
            "parse_edge_ratio",
            "parse_threshold",
            "parse_working_size",
        ],
        "prepare": ["aspect_crop_box", "to_working_size", "zoom_crop"],
        "provenance": ["ObjectSummary"],
        "plan": ["BuildPlan", "plan_build"],
        "run": ["BuildResult", "build_stimulus_set", "run_plan"],
    },
)
