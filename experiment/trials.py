"""A session's planned trials: :class:`Trial` and the ordered :class:`Schedule` of them.

They sit below both the session, which draws a schedule (:mod:`experiment.session.schedule`),
and the trial log, which stores it and reads it back (:mod:`experiment.log`), so neither of those
rooms imports the other for them. Plain data, no imports from the rest of ``experiment``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import asdict, dataclass, fields

__all__ = ["Trial", "Schedule", "balanced_latin_square"]


@dataclass(frozen=True)
class Trial:
    """One planned trial.

    Parameters
    ----------
    index : int
        Position in the schedule, 0-based; unique in a session.
    part : {'training', 'main'}
    block : int
        Block number in the schedule, 1-based; a block is shown without a break in its order.
    object, object_name : str
        Object id (``objects.csv``) and its name.
    condition : str
        ``'cluttered'``, ``'decluttered'``, ``'photo'``, ... or a de-clutter method's name.
    level : int
        1 = fewest pixels ... 8 = full resolution.
    window : int
        Compression window, px.
    pixels : int
        Pixels of the stimulus (width x height).
    path : str
        Image path relative to the stimulus set.
    sha256 : str
        Expected SHA-256 of the image file.
    pass_allowed_after_s : float
        Seconds after onset from which a pass is accepted.
    repetition : int
        0-based repetition of its block entry.
    break_before : bool
        Whether a break screen comes before this trial.
    """

    index: int
    part: str
    block: int
    object: str
    object_name: str
    condition: str
    level: int
    window: int
    pixels: int
    path: str
    sha256: str
    pass_allowed_after_s: float
    repetition: int = 0
    break_before: bool = False

    def to_dict(self) -> dict:
        """Return the trial as a plain dict (column name -> value)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> Trial:
        """Build a trial from :meth:`to_dict` output or a schedule row."""
        names = [f.name for f in fields(cls)]
        kw = {n: data[n] for n in names if n in data}
        kw["break_before"] = bool(kw.get("break_before", False))
        return cls(**kw)


class Schedule:
    """The ordered, immutable list of a session's trials."""

    def __init__(self, trials: tuple[Trial, ...] | list[Trial]) -> None:
        self.trials = tuple(trials)
        for i, t in enumerate(self.trials):
            if t.index != i:
                raise ValueError(f"trial indices must be 0..n-1 in order, got {t.index} at {i}")

    def __len__(self) -> int:
        return len(self.trials)

    def __getitem__(self, i: int) -> Trial:
        return self.trials[i]

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Schedule) and self.trials == other.trials

    __hash__ = None  # type: ignore[assignment]

    def iter_trials(self, start_after: int | None = None) -> Iterator[Trial]:
        """Yield the trials after index ``start_after`` (all of them for None), in order."""
        first = 0 if start_after is None else start_after + 1
        yield from self.trials[first:]

    def part(self, part: str) -> tuple[Trial, ...]:
        """Return the trials of one part (``'training'`` or ``'main'``)."""
        return tuple(t for t in self.trials if t.part == part)


def balanced_latin_square(n: int) -> list[list[int]]:
    """Return the rows of a balanced (Williams) Latin square of ``n`` conditions.

    Every condition comes at every position equally often and, for even ``n``, follows every
    other condition once; odd ``n`` needs the mirrored rows too (``2 n`` rows).

    References
    ----------
    Williams, E. J. (1949). Experimental designs balanced for the estimation of residual
    effects of treatments. Australian Journal of Chemistry, 2(2), 149-168.

    Examples
    --------
    >>> balanced_latin_square(2)
    [[0, 1], [1, 0]]
    >>> balanced_latin_square(4)[1]
    [1, 2, 0, 3]
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    first, lo, hi = [0], 1, n - 1
    while len(first) < n:
        first.append(lo)
        lo += 1
        if len(first) < n:
            first.append(hi)
            hi -= 1
    rows = [[(c + r) % n for c in first] for r in range(n)]
    if n % 2:
        rows += [row[::-1] for row in rows]
    return rows
