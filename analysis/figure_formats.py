"""The file formats a report's figures are saved in, and the ``--figure-formats`` option's parser.

Apart from :mod:`analysis.figures` (which imports matplotlib), so that the command line checks the
option, and the report links the files, without importing matplotlib.

By default a figure is saved as a 300 dpi PNG (shown in ``report.md``) and a PDF (vector, with its
text as text: what journals take); SVG, a second vector copy that costs as much to write as the
PDF, is written only when asked for (``--figure-formats png,pdf,svg``).
"""

from __future__ import annotations

__all__ = [
    "FIGURE_FORMATS",
    "DEFAULT_FIGURE_FORMATS",
    "parse_figure_formats",
    "figure_links",
    "FORMATS_HELP",
]

#: Every format a figure can be saved in, in the order files are written and linked.
FIGURE_FORMATS: tuple[str, ...] = ("png", "pdf", "svg")
#: Formats written when none are asked for: the PNG shown in the report and a vector PDF.
DEFAULT_FIGURE_FORMATS: tuple[str, ...] = ("png", "pdf")
#: Help of the ``--figure-formats`` option.
FORMATS_HELP: str = (
    "Figure files, comma-separated: png (300 dpi, shown in report.md), pdf (vector), svg "
    "(vector, on request: it costs as much to write as the pdf)."
)


def parse_figure_formats(text: str) -> tuple[str, ...]:
    """Return the formats named in ``text`` (comma-separated), in :data:`FIGURE_FORMATS` order.

    Parameters
    ----------
    text : str
        For example ``"png,pdf,svg"``; case and spaces are ignored, repeats kept once.

    Returns
    -------
    tuple of str

    Raises
    ------
    ValueError
        An unknown format, or none at all (the message names the option and the choices).

    Examples
    --------
    >>> parse_figure_formats("SVG, png")
    ('png', 'svg')
    """
    names = [w.strip().lower() for w in str(text).split(",") if w.strip()]
    bad = [w for w in names if w not in FIGURE_FORMATS]
    if bad or not names:
        raise ValueError(
            f"--figure-formats must be a comma-separated list of {', '.join(FIGURE_FORMATS)}; "
            f"got {text!r}"
        )
    return tuple(f for f in FIGURE_FORMATS if f in names)


def figure_links(name: str, formats: tuple[str, ...]) -> str:
    """Return a Markdown list item linking the files of figure ``name`` written in ``formats``.

    The PNG (when written) is the item's main link, the other formats follow in parentheses.

    Parameters
    ----------
    name : str
        File stem.
    formats : tuple of str
        Formats written (:func:`parse_figure_formats`).

    Returns
    -------
    str

    Examples
    --------
    >>> figure_links("fig8", ("png", "pdf"))
    '- [fig8](fig8.png) ([PDF](fig8.pdf))'
    >>> figure_links("fig8", ("svg",))
    '- fig8 ([SVG](fig8.svg))'
    """
    others = ", ".join(f"[{f.upper()}]({name}.{f})" for f in formats if f != "png")
    head = f"[{name}]({name}.png)" if "png" in formats else name
    return f"- {head}" + (f" ({others})" if others else "")
