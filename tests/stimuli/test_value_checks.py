"""The shared checks of typed values: a finite number, an ``AxB`` pair."""

from __future__ import annotations

import numpy as np
import pytest

from stimuli.errors import InputError
from stimuli.resources import finite_number, parse_pair


class _Refused(Exception):
    pass


@pytest.mark.parametrize("value", [1, 2.5, np.float32(-0.25), "3"])
def test_finite_number_returns_the_float(value):
    assert finite_number(value, "x") == float(value)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (None, r"^x must be a number, got None$"),
        ("soon", r"^x must be a number, got 'soon'$"),
        (float("nan"), r"^x must be finite, got nan$"),
        (np.inf, r"^x must be finite, got inf$"),
    ],
)
def test_finite_number_refuses_no_number_and_non_finite(value, message):
    with pytest.raises(InputError, match=message):
        finite_number(value, "x")


def test_finite_number_names_what_is_expected_with_the_callers_error():
    with pytest.raises(_Refused, match=r"^t must be a number of seconds, got 'soon'$"):
        finite_number("soon", "t", expected="a number of seconds", error=_Refused)


@pytest.mark.parametrize(
    ("text", "cast", "want"),
    [("38x25", int, (38, 25)), ("1080X720", int, (1080, 720)), ("10x7.5", float, (10.0, 7.5))],
)
def test_parse_pair_keeps_the_typed_order(text, cast, want):
    assert parse_pair(text, "--grid must be COLSxROWS", cast=cast) == want


@pytest.mark.parametrize("text", ["38", "38by25", "1x2x3", "x25", "2.5x3"])
def test_parse_pair_refuses_anything_but_two_values(text):
    with pytest.raises(InputError, match=rf"^--grid must be COLSxROWS, got '{text}'$"):
        parse_pair(text, "--grid must be COLSxROWS")


def test_parse_pair_raises_the_callers_error():
    with pytest.raises(_Refused, match=r"^--size must be WIDTHxHEIGHT, got 'big'$"):
        parse_pair("big", "--size must be WIDTHxHEIGHT", error=_Refused)
