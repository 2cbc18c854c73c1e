"""A griffe extension (mkdocs.yml): no missing-type warnings in the modules listed here.

A listed name covers its submodules too (``agents.fuzzy`` covers ``agents.fuzzy.kernels``).

The compiled (numba) kernels of these modules are typed by numba, not by annotations (see
pyproject's mypy override), and their docstrings do not give the types either, so griffe warns
"No type or annotation for parameter" for each argument. Only those objects skip that one check;
every other docstring warning still fails ``mkdocs build --strict``. Drop a module from the set
once its kernels' docstrings give the types (``name (type): ...``), as agents/ccc_laws.py's do.
"""

from __future__ import annotations

from typing import Any

import griffe

UNTYPED_DOCSTRINGS = frozenset({"agents.fuzzy.kernels", "contour_gym.motion"})


class UntypedKernelDocstrings(griffe.Extension):
    """Turn off ``warn_missing_types`` for the functions of :data:`UNTYPED_DOCSTRINGS`."""

    def on_function_instance(self, *, func: griffe.Function, **kwargs: Any) -> None:
        """Set the docstring's parser option when the function's module is listed."""
        module = func.module.path
        listed = any(module == m or module.startswith(m + ".") for m in UNTYPED_DOCSTRINGS)
        if func.docstring is not None and listed:
            func.docstring.parser_options = {
                **func.docstring.parser_options, "warn_missing_types": False,
            }
