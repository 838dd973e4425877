"""The robustness modules and the controller names built from them (the one list of both).

A controller is nominal IS-MPC plus a subset of :data:`MODULES`. Its name is ``nominal`` (no
module), ``robust`` (all three), a module name, or module names joined by ``+``
(``observer+timing``).
"""

from __future__ import annotations

from collections.abc import Iterable

from ..exceptions import ParameterError

#: The robustness modules, in their canonical order (spec §11-§13).
MODULES: tuple[str, ...] = ("observer", "restriction", "timing")


def check_modules(modules: Iterable[str]) -> tuple[str, ...]:
    """``modules`` in canonical order.

    Raises
    ------
    ParameterError
        A name that is not in :data:`MODULES`.
    """
    names = tuple(modules)
    unknown = [m for m in names if m not in MODULES]
    if unknown:
        raise ParameterError(f"unknown module {unknown[0]!r}; modules are: {', '.join(MODULES)}")
    return tuple(m for m in MODULES if m in names)


def controller_label(modules: Iterable[str]) -> str:
    """Name of the controller with ``modules``: ``nominal``, ``robust`` or ``a+b``."""
    names = check_modules(modules)
    if not names:
        return "nominal"
    if names == MODULES:
        return "robust"
    return "+".join(names)


def controller_modules(name: str) -> tuple[str, ...]:
    """Modules of a controller name (the inverse of :func:`controller_label`).

    Raises
    ------
    ParameterError
        For an unknown name or a module named twice.
    """
    if not isinstance(name, str) or not name.strip():
        raise ParameterError("controller names must be non-empty strings")
    name = name.strip()
    if name == "nominal":
        return ()
    if name == "robust":
        return MODULES
    parts = [p.strip() for p in name.split("+")]
    if any(p not in MODULES for p in parts) or len(set(parts)) != len(parts):
        raise ParameterError(
            f"unknown controller {name!r}; use nominal, robust, {', '.join(MODULES)} or modules joined by '+'"
        )
    return check_modules(parts)


def parse_controllers(text: str) -> tuple[str, ...]:
    """Comma-separated controller names, e.g. ``nominal,timing,robust``, none repeated.

    Raises
    ------
    ParameterError
        An empty list, an unknown name, or two names for the same modules.
    """
    if not isinstance(text, str):
        raise ParameterError(f"controllers must be a comma-separated string, got {text!r}")
    names = tuple(p.strip() for p in text.split(",") if p.strip())
    if not names:
        raise ParameterError(f"controllers: give at least one of nominal, robust, {', '.join(MODULES)}")
    seen: dict[tuple[str, ...], str] = {}
    for name in names:
        modules = controller_modules(name)
        if modules in seen:
            raise ParameterError(f"controllers: {name!r} repeats {seen[modules]!r}")
        seen[modules] = name
    return names


def parse_modules(controller: str, modules: str | None = None) -> tuple[str, ...]:
    """Modules from ``--controller nominal|robust`` and an optional ``--modules a,b``.

    Raises
    ------
    ParameterError
        An unknown controller or module.
    """
    if modules is not None:
        return check_modules(m.strip() for m in modules.split(",") if m.strip())
    if controller in ("nominal", "robust"):
        return controller_modules(controller)
    raise ParameterError(f"unknown controller {controller!r}; use nominal or robust (or --modules)")
