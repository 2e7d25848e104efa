"""Parameter constraints, checked the same way for estimators and free functions.

scikit-learn's own constraint machinery lives in private modules that may change between
releases, so the package carries this small equivalent: estimators declare
``_parameter_constraints`` as scikit-learn's do, free functions use
:func:`validate_params`, and both raise :class:`InvalidParameterError` (a ``ValueError``
and a ``TypeError``, as scikit-learn's) naming the parameter, what is allowed and what was
given.
"""

from __future__ import annotations

import functools
import inspect
import math
from numbers import Integral, Real

import numpy as np

__all__ = [
    "N_JOBS",
    "HasMethods",
    "Interval",
    "InvalidParameterError",
    "Numbers",
    "Options",
    "validate_params",
]


class InvalidParameterError(ValueError, TypeError):
    """A parameter has a value outside its constraints."""


class Interval:
    """Numbers of ``kind`` (``Integral`` or ``Real``) between ``left`` and ``right``.

    ``None`` leaves a side open to infinity; ``closed`` is ``"left"``, ``"right"``,
    ``"both"`` or ``"neither"``. Booleans are never numbers here, and NaN never passes.
    """

    def __init__(self, kind, left, right, *, closed: str):
        self.kind, self.left, self.right, self.closed = kind, left, right, closed

    def __call__(self, value) -> bool:
        if isinstance(value, bool | np.bool_) or not isinstance(value, self.kind):
            return False
        if isinstance(value, Real) and math.isnan(value):
            return False
        if isinstance(value, np.generic):  # compared as a Python number: a float32
            value = value.item()  # against 1e300 overflowed in the cast (a warning)
        if self.left is not None:
            if value < self.left or (value == self.left and self.closed in ("right", "neither")):
                return False
        if self.right is not None:
            if value > self.right or (value == self.right and self.closed in ("left", "neither")):
                return False
        return True

    def __str__(self) -> str:
        kind = "an int" if self.kind is Integral else "a float"
        low = "-inf" if self.left is None else self.left
        high = "inf" if self.right is None else self.right
        left = "[" if self.closed in ("left", "both") and self.left is not None else "("
        right = "]" if self.closed in ("right", "both") and self.right is not None else ")"
        return f"{kind} in the range {left}{low}, {high}{right}"


class Options:
    """One of a fixed collection of values (strings: the names of a registry)."""

    def __init__(self, options):
        self.options = tuple(options)

    def __call__(self, value) -> bool:
        return isinstance(value, str) and value in self.options

    def __str__(self) -> str:
        return "one of " + ", ".join(repr(o) for o in self.options)


class Numbers:
    """A sequence of numbers: a tuple, a list or a 1-D array of real numbers (no bools,
    no strings), of ``length`` entries when given; ``None`` entries (an end to learn)
    are allowed with ``none=True``. NaN passes: where it is allowed, the caller says
    what it means."""

    def __init__(self, length: int | None = None, *, none: bool = False):
        self.length, self.none = length, none

    def __call__(self, value) -> bool:
        if isinstance(value, np.ndarray):
            if value.ndim != 1 or value.dtype.kind not in "iuf":
                return False
        elif not isinstance(value, tuple | list):
            return False
        if self.length is not None and len(value) != self.length:
            return False
        return all(
            (self.none and item is None)
            or (isinstance(item, Real) and not isinstance(item, bool | np.bool_))
            for item in value
        )

    def __str__(self) -> str:
        size = "" if self.length is None else f"{self.length} "
        extra = " (each possibly None)" if self.none else ""
        return f"a tuple, list or 1-D array of {size}numbers{extra}"


class HasMethods:
    """An object with the named methods (duck typing, e.g. a ``joblib.Memory``)."""

    def __init__(self, methods):
        self.methods = tuple(methods)

    def __call__(self, value) -> bool:
        return all(callable(getattr(value, m, None)) for m in self.methods)

    def __str__(self) -> str:
        return "an object with methods " + ", ".join(self.methods)


def _is_random_state(value) -> bool:
    if isinstance(value, Integral) and not isinstance(value, bool):
        return 0 <= value < 2**32  # numpy's seeds
    return value is None or isinstance(value, np.random.RandomState)


def _describe(constraint) -> str:
    if constraint is None:
        return "None"
    if constraint == "random_state":
        return "an int in [0, 2**32 - 1], a numpy.random.RandomState or None"
    if constraint == "boolean":
        return "a bool"
    if isinstance(constraint, type):
        return f"an instance of {constraint.__name__}"
    return str(constraint)


def _satisfies(value, constraint) -> bool:
    if constraint is None:
        return value is None
    if constraint == "random_state":
        return _is_random_state(value)
    if constraint == "boolean":
        return isinstance(value, bool | np.bool_)
    if isinstance(constraint, type):
        if constraint in (int, Integral) and isinstance(value, bool):
            return False
        return isinstance(value, constraint)
    return constraint(value)


def check_params(constraints: dict, params: dict, caller: str) -> None:
    """Raise :class:`InvalidParameterError` for the first parameter outside its list."""
    for name, allowed in constraints.items():
        if name not in params:
            continue
        value = params[name]
        if any(_satisfies(value, c) for c in allowed):
            continue
        choices = [_describe(c) for c in allowed]
        text = choices[0] if len(choices) == 1 else ", ".join(choices[:-1]) + " or " + choices[-1]
        raise InvalidParameterError(
            f"The {name!r} parameter of {caller} must be {text}. Got {value!r} instead."
        )


def validate_params(constraints: dict):
    """Decorator checking a free function's arguments against ``constraints``."""

    def decorate(func):
        parameters = inspect.signature(func).parameters
        names = list(parameters)
        defaults = {
            name: p.default
            for name, p in parameters.items()
            if name in constraints and p.default is not inspect.Parameter.empty
        }

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            # Cheaper than Signature.bind, for functions called in loops; a wrong call
            # still fails as usual when ``func`` is called.
            values = dict(defaults)
            values.update(zip(names, args, strict=False))
            values.update(kwargs)
            check_params(constraints, values, func.__qualname__)
            return func(*args, **kwargs)

        return wrapper

    return decorate


#: Most workers joblib accepts (its own limit, refused there with a raw message).
MAX_JOBS = 1_000_000

#: The constraint of every ``n_jobs``: None, 1 or more workers, or -1, -2... (all the
#: cores, all but one...); 0 means nothing.
N_JOBS = [
    Interval(Integral, 1, MAX_JOBS, closed="both"),
    Interval(Integral, -MAX_JOBS, -1, closed="both"),
    None,
]
