"""Exceptions raised by dynval, one class per language-neutral error kind.

The kind names are shared verbatim with the C++ core (``dynval::error_kind``), the golden
corpus (``expected.error``) and the port protocol (``error`` lines), so :func:`error_class`
is the one place that maps a kind name back to a Python class.
"""

from __future__ import annotations

__all__ = [
    "InputError",
    "InvalidType",
    "InvalidShape",
    "ShapeMismatch",
    "TooFewSamples",
    "NonFiniteInput",
    "InvalidParameter",
    "ERROR_KINDS",
    "error_class",
]


class InputError(ValueError):
    """Base class of every input error raised by dynval.

    Catching :class:`ValueError` catches all of them. Each subclass carries the contract's
    error kind in the class attribute :attr:`kind`.

    Examples
    --------
    >>> import dynval
    >>> try:
    ...     dynval.rmse([1.0, 2.0], [1.0])
    ... except dynval.InputError as exc:
    ...     print(exc.kind)
    ShapeMismatch
    """

    kind: str = "InputError"


class InvalidType(InputError, TypeError):
    """An array argument is not array-like of real numbers (also a :class:`TypeError`)."""

    kind = "InvalidType"


class InvalidShape(InputError):
    """An array has the wrong number of dimensions, or zero columns."""

    kind = "InvalidShape"


class ShapeMismatch(InputError):
    """Arrays that must agree in shape do not."""

    kind = "ShapeMismatch"


class TooFewSamples(InputError):
    """Fewer samples than the function's minimum."""

    kind = "TooFewSamples"


class NonFiniteInput(InputError):
    """NaN or +/-inf in the data with ``nan_policy="raise"``."""

    kind = "NonFiniteInput"


class InvalidParameter(InputError):
    """A keyword is out of range, of the wrong kind, or an unknown option."""

    kind = "InvalidParameter"


# Contract §2 order: the order in which checks run.
ERROR_KINDS: tuple[str, ...] = (
    "InvalidType",
    "InvalidShape",
    "ShapeMismatch",
    "TooFewSamples",
    "NonFiniteInput",
    "InvalidParameter",
)

_CLASSES = {
    cls.kind: cls
    for cls in (InvalidType, InvalidShape, ShapeMismatch, TooFewSamples, NonFiniteInput, InvalidParameter)
}


def error_class(kind: str) -> type[InputError]:
    """Return the exception class for a contract error kind.

    Parameters
    ----------
    kind : str
        One of :data:`ERROR_KINDS`.

    Returns
    -------
    type
        The matching subclass of :class:`InputError`.

    Raises
    ------
    KeyError
        If ``kind`` is not a contract error kind.

    Examples
    --------
    >>> error_class("TooFewSamples").__name__
    'TooFewSamples'

    An unknown kind is a KeyError; the base class is not a contract kind:

    >>> error_class("InputError")
    Traceback (most recent call last):
        ...
    KeyError: "unknown error kind 'InputError'; expected one of ('InvalidType', ...)"
    """
    try:
        return _CLASSES[kind]
    except KeyError:
        raise KeyError(f"unknown error kind {kind!r}; expected one of {ERROR_KINDS}") from None
