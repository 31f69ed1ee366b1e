r"""The one rule for subject codes: what ``session run`` and ``active run`` accept as ``--subject``.

A subject code leaves the lab: it is a column of every exported data file, a row of
``participants.tsv`` and part of each data file's name. So a code must name nobody and be safe
as a file-name part. :func:`check_subject_code` refuses, with one line naming ``--subject``:

* an empty code, or one with spaces around it;
* a code longer than :data:`stimuli.resources.MAX_ID_CHARS` characters;
* control characters (tabs, newlines, escape sequences: anything not printable);
* path characters: ``/``, ``\`` or ``..``;
* a space inside the code (a full name such as ``Ann Smith``), or a name-shaped code of
  capitalised words (``Ann_Smith``, ``Ann.Smith``);
* what ``--participant`` refuses in a value (:func:`experiment.data.identifying.identifying_value`):
  an ``@`` (an e-mail address), a phone number, a full calendar date;
* a code without a letter or digit (the data file name keeps only letters and digits).

Codes such as ``S01``, ``P-017``, ``pilot_3`` or ``site2.s14`` pass.
"""

from __future__ import annotations

import re

from experiment.data.identifying import identifying_value
from experiment.errors import ConfocalError
from stimuli.resources import MAX_ID_CHARS

__all__ = ["SubjectCodeError", "subject_code_problem", "check_subject_code"]

#: Two or more capitalised words of letters joined by ``_``, ``.`` or ``-``: a name, not a code.
_NAME_SHAPED = re.compile(r"[A-Z][a-z]+(?:[._-][A-Z][a-z]+)+")


class SubjectCodeError(ConfocalError):
    """A ``--subject`` code the rule refuses (one line naming the option and why)."""


def subject_code_problem(code: str) -> str | None:
    r"""Return why ``code`` is not an acceptable subject code, or None when it is.

    Examples
    --------
    >>> subject_code_problem("S01") is None
    True
    >>> subject_code_problem("a/b")
    'holds a path character (/, \\ or ..); subject codes become file names'
    """
    text = str(code)
    if not text.strip():
        return "is empty; give a subject code such as S01"
    if text != text.strip():
        return "has spaces around it; give the subject code alone, e.g. S01"
    if len(text) > MAX_ID_CHARS:
        return f"must be at most {MAX_ID_CHARS} characters, got {len(text)}"
    if not text.isprintable():
        return "holds a control character (a tab, newline or escape); give a code such as S01"
    if "/" in text or "\\" in text or ".." in text:
        return "holds a path character (/, \\ or ..); subject codes become file names"
    if any(c.isspace() for c in text):
        return "holds a space (a full name?); a subject code is one word that names nobody"
    if _NAME_SHAPED.fullmatch(text):
        return "looks like a person's name; a subject code must name nobody, e.g. S01"
    reason = identifying_value(text)
    if reason is not None:
        return f"{reason}; a subject code is shared with the data and must name nobody"
    if not re.search(r"[A-Za-z0-9]", text):
        return "has no letter or digit, so it cannot name a data file"
    return None


def check_subject_code(code: str, option: str = "--subject") -> str:
    """Return ``code`` if it follows the subject-code rule; refuse it with one line otherwise.

    Parameters
    ----------
    code : str
        The code as typed.
    option : str
        The option named in the message.

    Raises
    ------
    SubjectCodeError
        Naming the option, the code (its first 20 characters) and what is wrong.
    """
    problem = subject_code_problem(code)
    if problem is not None:
        shown = repr(code if len(code) <= 20 else code[:20] + "...")
        raise SubjectCodeError(f"{option} {shown} {problem}")
    return code
