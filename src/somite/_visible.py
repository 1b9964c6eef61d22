"""Text a user or a received file supplies, made safe to show: its control characters written
out (``\\x1b``) rather than sent.

A campaign's name (its file's name), its titles and labels travel in ``campaign.json`` and in
every pack: an ESC there would drive the terminal of whoever runs ``campaign status``; a
bidirectional override (U+202E) would show text other than what is stored; a line break would
split a table's row or a one-line message.
"""

from __future__ import annotations

import re

_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028\u2029\u202a-\u202e"
                      "\u2066-\u2069]")


def visible(text: object) -> str:
    """``str(text)`` with every control character as its Python escape (``\\x1b``,
    ``\\u202e``, ``\\n``); other text as it is."""
    return _CONTROL.sub(lambda m: m[0].encode("unicode_escape").decode("ascii"), str(text))


def for_figure(text: object) -> str:
    """:func:`visible`, and ``$`` escaped, for a label matplotlib draws: a pair of ``$`` would
    be parsed as mathtext, and a label such as ``a$\\frac{$`` end the drawing in an error."""
    return visible(text).replace("$", r"\$")


__all__ = ["for_figure", "visible"]
