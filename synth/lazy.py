"""Names of a package imported on first use (PEP 562).

A package that re-exports heavy modules (trimesh, FCL, scipy, matplotlib) lists them in a
table and lets :func:`lazy_attributes` import each on first look-up, so that importing the
package, or one light module of it (the command line's ``--help``), does not load them.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable

__all__ = ["lazy_attributes"]


def lazy_attributes(package: str, table: dict[str, str]) -> Callable[[str], object]:
    """A module ``__getattr__`` importing each name of ``table`` from its module on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    table : dict of str to str
        Name to the module that defines it.

    Returns
    -------
    callable
        Assign it to the package's ``__getattr__``; a name found is stored in the package,
        so later look-ups do not call it again.

    Examples
    --------
    >>> __getattr__ = lazy_attributes(__name__, {"plan_part": "synth.plan.search"})
    """

    def __getattr__(name: str) -> object:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)
        return value

    return __getattr__
