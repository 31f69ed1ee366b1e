"""What the viewer shows: a still light field or a video of light-field frames, and input scripts.

:func:`open_source` opens a light field, a folder of light-field frames (a video) or a synthetic
scene, with the view crop (the capture's vignette removed by default); :func:`read_script` reads
the JSON-lines event scripts ``confocal view --script`` replays.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from experiment.errors import ConfocalError
from stimuli.lightfield import LightField

__all__ = ["LightFieldSource", "open_source", "read_script"]


class LightFieldSource:
    """A still light field or a video of light-field frames (loaded one at a time).

    Parameters
    ----------
    frames : list of Path, or a LightField
        Frame inputs in order, or one loaded still.
    loader : dict
        Keyword arguments for :func:`stimuli.lightfield.load_lightfield`.
    view_crop : (x, y, w, h), optional
        Crop every view first (:meth:`stimuli.lightfield.LightField.cropped`).

    Attributes
    ----------
    view_crop : (x, y, w, h) or None
        The crop applied.
    """

    def __init__(
        self,
        frames: list[Path] | LightField,
        loader: dict | None = None,
        *,
        view_crop: tuple[int, int, int, int] | None = None,
    ) -> None:
        self._loader = loader or {}
        self._crop = view_crop
        self.view_crop = view_crop
        if isinstance(frames, LightField) and view_crop is not None:
            frames = frames.cropped(view_crop)
        if isinstance(frames, LightField):
            self._paths: list[Path] = []
            self._cache = {0: frames.gray()}
        else:
            self._paths = list(frames)
            self._cache = {}
        self.n_frames = max(1, len(self._paths))

    def frame(self, k: int) -> LightField:
        """Return frame ``k`` as a grey light field (the previous frame stays cached)."""
        if k not in self._cache:
            from stimuli.lightfield import load_lightfield

            lf = load_lightfield(self._paths[k], **self._loader).gray()
            if self._crop is not None:
                lf = lf.cropped(self._crop)
            first = self._cache.get(0)
            if first is not None and lf.views.shape != first.views.shape:
                raise ConfocalError(
                    f"{self._paths[k]}: frame shape {lf.views.shape} differs from the first "
                    f"frame's {first.views.shape}"
                )
            keep = {0, k - 1}
            self._cache = {i: v for i, v in self._cache.items() if i in keep}
            self._cache[k] = lf
        return self._cache[k]


def open_source(
    path: Path, *, view_crop: tuple[int, int, int, int] | str | None = "auto", **loader: Any
) -> LightFieldSource:
    """Open a light field (any input ``confocal lightfield`` reads) or a folder of frames.

    A folder is a *video* when it holds no view images of its own but two or more light-field
    inputs (sub-folders of views, ``.npy``/``.npz`` files), taken in name order.

    ``view_crop``: a box ``(x, y, w, h)`` cropped from every view, None for none, or ``"auto"``:
    the box that leaves out the capture's vignette rim and clipped strip, found in the (first)
    frame's views as every command finds it (:func:`stimuli.vignette.capture_crop`; none when
    there is nothing to leave out). The box used is :attr:`LightFieldSource.view_crop`.
    """
    if isinstance(view_crop, str):
        if view_crop != "auto":
            raise ConfocalError(f"view_crop must be a box, None or 'auto', got {view_crop!r}")
        from stimuli.vignette import capture_crop

        src = open_source(path, view_crop=None, **loader)
        box = capture_crop(src.frame(0).gray())
        if box is None:
            return src
        return open_source(path, view_crop=box, **loader)
    from stimuli.lightfield import load_lightfield

    path = Path(path)
    if not path.exists():
        raise ConfocalError(f"{path}: light field not found")
    if path.is_dir():
        images = [
            p for p in path.iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg", ".tif")
        ]
        frames = sorted(
            p for p in path.iterdir() if p.is_dir() or p.suffix.lower() in (".npy", ".npz")
        )
        if not images and len(frames) >= 2:
            src = LightFieldSource(frames, loader, view_crop=view_crop)
            src.frame(0)
            return src
    return LightFieldSource(load_lightfield(path, **loader), view_crop=view_crop)


def read_script(path: Path) -> list[dict]:
    """Read a scripted-event file: JSON lines ``{"kind": ..., "payload": {...}}``.

    Raises
    ------
    ConfocalError
        Unreadable file, or a line that is not such an object (named by line number).
    """
    out = []
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfocalError(f"{path}: cannot read the event script ({exc.strerror})") from None
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            ev = json.loads(line)
        except json.JSONDecodeError:
            raise ConfocalError(f"{path}:{n}: not JSON: {line[:40]!r}") from None
        if not isinstance(ev, dict) or not isinstance(ev.get("kind"), str):
            raise ConfocalError(f"{path}:{n}: expected {{'kind': ..., 'payload': {{...}}}}")
        if not isinstance(ev.get("payload", {}), dict):
            raise ConfocalError(f"{path}:{n}: payload must be an object")
        out.append({"kind": ev["kind"], "payload": ev.get("payload", {})})
    return out
