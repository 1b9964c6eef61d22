"""User-facing errors: one line that names the field and the offending value."""


class SomiteError(ValueError):
    """Bad input from a user. The CLI prints ``error: <message>`` and exits with code 2."""


def bad(field: str, value: object, why: str) -> SomiteError:
    """Build the standard error for ``field`` holding ``value``, with the reason ``why``."""
    return SomiteError(f"{field}={value!r}: {why}")
