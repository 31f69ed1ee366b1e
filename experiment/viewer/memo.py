"""The viewer's small memories: a bounded least-recently-used map and the averaging history.

:class:`~experiment.viewer.app.Viewer` keeps what it has drawn (implant pictures, automatic
thresholds) in :class:`LruCache` objects and the last video frames' electrode values in a
:class:`FrameAverage`, instead of loose dictionaries and counters of its own.
"""

from __future__ import annotations

from collections import OrderedDict, deque
from collections.abc import Hashable
from typing import Any

import numpy as np

__all__ = ["LruCache", "FrameAverage"]


class LruCache:
    """A map that keeps its ``size`` most recently used entries.

    Parameters
    ----------
    size : int >= 1

    Examples
    --------
    >>> c = LruCache(2)
    >>> c.put("a", 1); c.put("b", 2); _ = c.get("a"); c.put("c", 3)
    >>> sorted(c.keys())
    ['a', 'c']
    """

    def __init__(self, size: int) -> None:
        self.size = int(size)
        self._items: OrderedDict[Hashable, Any] = OrderedDict()

    def get(self, key: Hashable) -> Any:
        """Return the value of ``key`` (and mark it used), or None."""
        value = self._items.get(key)
        if value is not None:
            self._items.move_to_end(key)
        return value

    def put(self, key: Hashable, value: Any) -> None:
        """Keep ``value`` under ``key``, forgetting the least recently used beyond ``size``."""
        self._items[key] = value
        self._items.move_to_end(key)
        while len(self._items) > self.size:
            self._items.popitem(last=False)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._items

    def __len__(self) -> int:
        return len(self._items)

    def keys(self) -> list[Hashable]:
        """Return the keys, least recently used first."""
        return list(self._items)


class FrameAverage:
    """The mean of the implant's electrode values over the last ``n`` video frames.

    Redrawing the same frame (a depth step, a key) replaces its entry instead of adding one;
    a new ``key`` (implant, grey levels, zoom) or averaging switched off starts afresh.

    Parameters
    ----------
    n : int >= 1
        Frames averaged.
    """

    def __init__(self, n: int) -> None:
        self._history: deque[np.ndarray] = deque(maxlen=int(n))
        self._key: Hashable = None
        self._frame = -1

    def __len__(self) -> int:
        return len(self._history)

    @property
    def frames(self) -> tuple[np.ndarray, ...]:
        """The electrode values averaged now, oldest first."""
        return tuple(self._history)

    def add(self, key: Hashable, frame: int, cells: np.ndarray, *, on: bool) -> np.ndarray:
        """Add the electrode values of ``frame``; return the mean (float32)."""
        if not on or key != self._key:
            self._history.clear()
            self._key = key
        if self._history and self._frame == frame:
            self._history[-1] = cells
        else:
            self._history.append(cells)
        self._frame = frame
        return np.mean(np.stack(self._history), axis=0).astype(np.float32)
