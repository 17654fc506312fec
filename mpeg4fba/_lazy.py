"""Names a package imports on first use (PEP 562), so that importing it stays quick.

>>> import types
>>> pkg = types.ModuleType("pkg")
>>> pkg.__getattr__, pkg.__dir__ = lazy_names(vars(pkg), {"sqrt": ("math", "sqrt")})
>>> pkg.sqrt(9.0), "sqrt" in vars(pkg)
(3.0, True)
"""
from __future__ import annotations

import importlib
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(namespace: dict, table: dict) -> tuple:
    """(``__getattr__``, ``__dir__``) for a module whose ``namespace`` (its ``globals()``)
    gets each name of ``table`` (name -> (module, attribute, or None for the module
    itself)) when it is first asked for; the value is then kept, so later lookups never
    come back here."""
    def __getattr__(name: str) -> Any:
        try:
            module, attribute = table[name]
        except KeyError:
            raise AttributeError(f"module {namespace.get('__name__')!r} has no attribute "
                                 f"{name!r}") from None
        value: Any = importlib.import_module(module)
        if attribute is not None:
            value = getattr(value, attribute)
        namespace[name] = value
        return value

    def __dir__() -> list:
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
