"""Public names of a package imported on first use (PEP 562 module ``__getattr__``).

A package whose public names live in heavy submodules lists where each one lives; importing
the package, or one light submodule of it, then loads none of the others.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from importlib import import_module

__all__ = ["lazy_names"]


def lazy_names(
    package: str, homes: Mapping[str, str], public: list[str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    homes : mapping of str to str
        Every lazily imported name and the submodule (relative to ``package``) it lives in.
    public : list of str
        The package's ``__all__``.

    Returns
    -------
    (__getattr__, __dir__)
        ``__getattr__(name)`` imports ``package.<homes[name]>`` and keeps the name in the
        package's namespace (later lookups do not come back here); an unknown name is an
        ``AttributeError``. ``__dir__()`` lists the namespace and ``public``.
    """

    def __getattr__(name: str) -> object:
        home = homes.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(f"{package}.{home}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted({*vars(sys.modules[package]), *public})

    return __getattr__, __dir__
