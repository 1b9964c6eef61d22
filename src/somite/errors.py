"""User-facing errors: one line that names the field and the offending value.

:class:`SomiteError` is a :class:`ValueError` (a value out of bounds, a name not known) and
:class:`SomiteTypeError` also a :class:`TypeError` (a value of the wrong type): a caller of
the Python API may catch either the standard exception or ``somite.SomiteError`` for both.
"""

import sys


class SomiteError(ValueError):
    """Bad input from a user. The CLI prints ``error: <message>`` and exits with code 2."""


class SomiteTypeError(SomiteError, TypeError):
    """Bad input of the wrong type (a string for a number, None for a body)."""


SHOWN = 100
"""Characters of a value an error shows: an integer of 500 digits or a whole JSON object is
cut, so that the line stays readable."""


def shown(value: object) -> str:
    """``repr(value)``, cut to :data:`SHOWN` characters; never itself an error."""
    try:
        text = repr(value)
    except ValueError:  # an integer too long for repr (sys.set_int_max_str_digits)
        text = f"<an integer of over {sys.get_int_max_str_digits()} digits>"
    except Exception:  # noqa: BLE001 - a user's object whose __repr__ fails
        text = f"<a {type(value).__name__}>"
    text = " ".join(text.split("\n"))
    if len(text) > SHOWN:
        text = f"{text[:SHOWN - 40]}...{text[-20:]} ({len(text)} characters)"
    return text


def bad(field: str, value: object, why: str) -> SomiteError:
    """Build the standard error for ``field`` holding ``value``, with the reason ``why``."""
    return SomiteError(f"{field}={shown(value)}: {why}")


def bad_type(field: str, value: object, expected: str) -> SomiteTypeError:
    """The standard error for ``field`` holding ``value`` of a type other than ``expected``."""
    return SomiteTypeError(f"{field}={shown(value)}: expected {expected}, "
                           f"not {type(value).__name__}")
