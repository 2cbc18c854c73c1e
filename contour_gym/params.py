"""Named parameters for your own components: the public home of :class:`Schema` and the checks.

A friction law, axis controller, estimator, CCC law or reward you register declares its
parameters once, by name, as a :class:`Schema` of :class:`Param` (default, check, doc). The
schema builds the float row its compiled function reads (validating each value and naming it
in errors) and gives that function its column indices by name (``SCHEMA.col.kp``). The checks
(``finite``, ``positive``, ``non_negative``, ...) take ``(value, name)`` and raise ValueError
naming the value; ``choice`` checks a name against the accepted ones (listing them) and
``as_finite_array`` an array's values and shape.

>>> pid = Schema("my_pid", kp=Param(check=positive, doc="1/s"), ki=0.0)
>>> pid.row(kp=2.0).tolist(), pid.col.ki
([2.0, 0.0], 1)
"""

from __future__ import annotations

from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import (
    as_finite_array,
    choice,
    finite,
    non_negative,
    number,
    positive,
    positive_or_inf,
    seed_value,
)

__all__ = [
    "Param",
    "Schema",
    "as_finite_array",
    "choice",
    "finite",
    "non_negative",
    "number",
    "positive",
    "positive_or_inf",
    "seed_value",
    "state_schema",
]
