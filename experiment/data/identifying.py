"""What makes a text identifying: an e-mail address, a phone number, a full calendar date.

One set of patterns for everything that leaves the lab: ``--participant`` values
(:func:`experiment.data.psychds.identifying_reason`), subject codes
(:mod:`experiment.data.subjects`) and the typed answers an export warns about.
"""

from __future__ import annotations

import re

__all__ = ["identifying_value", "identifying_answer"]

#: A phone number: 7 or more digits with only spaces, dots, dashes, brackets and a leading +.
_PHONE_RE = re.compile(r"\+?[\d\s().-]{7,}")
#: A full calendar date (2001-02-03, 3/2/2001, 03.02.01): a date of birth, or a visit date.
_DATE_RE = re.compile(r"\b(\d{4}[-/.]\d{1,2}[-/.]\d{1,2}|\d{1,2}[-/.]\d{1,2}[-/.]\d{2,4})\b")
#: In a typed answer: an e-mail address, or 7 or more digits of a phone number.
_EMAIL_IN_TEXT = re.compile(r"[^\s@]+@[^\s@]+\.[^\s@]+")
_PHONE_IN_TEXT = re.compile(r"(?<![\w.])\+?\d[\d\s().-]{5,}\d(?![\w.])")


def identifying_value(value: object) -> str | None:
    """Return why a text looks identifying (an e-mail, a phone number, a date), or None.

    The value half of :func:`experiment.data.psychds.identifying_reason`; also the subject-code
    rule's (:mod:`experiment.data.subjects`).

    Examples
    --------
    >>> identifying_value("ann@example.org")
    'has an @ (an e-mail address or handle)'
    >>> identifying_value("cup") is None
    True
    """
    text = str(value)
    if "@" in text:
        return "has an @ (an e-mail address or handle)"
    if _PHONE_RE.fullmatch(text.strip()) and sum(c.isdigit() for c in text) >= 7:
        return "looks like a phone number"
    if _DATE_RE.search(text):
        return "looks like a date (a date of birth identifies)"
    return None


def identifying_answer(text: object) -> str | None:
    """Return why a typed answer looks identifying (an e-mail address, a phone number), or None.

    Searched anywhere in the text: ``call me on 020 7946 0958`` is found.

    Examples
    --------
    >>> identifying_answer("write to ann@example.org")
    'holds an e-mail address'
    >>> identifying_answer("a cup") is None
    True
    """
    if not isinstance(text, str) or not text:
        return None
    if _EMAIL_IN_TEXT.search(text):
        return "holds an e-mail address"
    for m in _PHONE_IN_TEXT.finditer(text):
        if sum(c.isdigit() for c in m.group()) >= 7:
            return "holds a phone number"
    return None
