"""User-facing errors: one line that names the field and the offending value."""

import sys


class SomiteError(ValueError):
    """Bad input from a user. The CLI prints ``error: <message>`` and exits with code 2."""


SHOWN = 100
"""Characters of a value an error shows: an integer of 500 digits or a whole JSON object is
cut, so that the line stays readable."""


def bad(field: str, value: object, why: str) -> SomiteError:
    """Build the standard error for ``field`` holding ``value``, with the reason ``why``."""
    try:
        shown = repr(value)
    except ValueError:  # an integer too long for repr (sys.set_int_max_str_digits)
        shown = f"<an integer of over {sys.get_int_max_str_digits()} digits>"
    if len(shown) > SHOWN:
        shown = f"{shown[:SHOWN - 40]}...{shown[-20:]} ({len(shown)} characters)"
    return SomiteError(f"{field}={shown}: {why}")
