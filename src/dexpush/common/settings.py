"""Settings classes whose knobs live in small nested groups, and the flat names they replaced.

A settings class (a frozen dataclass) that groups its knobs (``ControllerSettings.stall.after_s``)
declares the flat names it had (``stall_after_s``) with :func:`grouped`. Those names keep working
as keyword arguments and in dicts read from files, with a ``FutureWarning`` that names the new
place, so an old script or TOML file is read as it was meant, never refused silently or misread.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import warnings
from typing import Any

__all__ = ["flat_names", "grouped", "upgrade_flat"]


def flat_names(cls: type) -> dict[str, tuple[str, str]]:
    """The flat names ``cls`` still reads: old name → (group field, field in the group)."""
    return getattr(cls, "_flat_names", {})


def _warn(cls: type, moved: dict[str, Any], where: str) -> None:
    new = ", ".join(f"{old} → {'.'.join(flat_names(cls)[old])}" for old in moved)
    warnings.warn(f"{where}: {new} (the old flat names are read as the new ones; write the new form)",
                  FutureWarning, stacklevel=4)


def upgrade_flat(cls: type, data: dict[str, Any], where: str, warn: bool = True) -> dict[str, Any]:
    """``data`` (field → value, nested groups as dicts) with ``cls``'s old flat names moved into their
    groups; a ``ValueError`` when a value is given both ways."""
    renames = flat_names(cls)
    moved = {k: data[k] for k in data if k in renames}
    if not moved:
        return data
    if warn:
        _warn(cls, moved, where)
    out = {k: v for k, v in data.items() if k not in renames}
    for old, value in moved.items():
        group, name = renames[old]
        sub = out.setdefault(group, {})
        if not isinstance(sub, dict):
            sub = out[group] = dataclasses.asdict(sub)
        if name in sub:
            raise ValueError(f"{where}: {old} and {group}.{name} are the same setting; give it once")
        sub[name] = value
    return out


def grouped(renames: dict[str, tuple[str, str]]):
    """Class decorator: ``cls(old_flat_name=v)`` sets ``cls(group=Group(name=v))`` with a ``FutureWarning``."""
    def wrap(cls: type) -> type:
        init = cls.__init__
        groups = {f.name: f for f in dataclasses.fields(cls)}

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:  # noqa: N807 (it is the class's __init__)
            moved = {k: kwargs.pop(k) for k in list(kwargs) if k in renames}
            if moved:
                _warn(cls, moved, cls.__name__)
                for old, value in moved.items():
                    group, name = renames[old]
                    base = kwargs.get(group)
                    if base is None:
                        base = groups[group].default_factory()   # type: ignore[misc]
                    kwargs[group] = dataclasses.replace(base, **{name: value})
            init(self, *args, **kwargs)

        __init__.__signature__ = inspect.signature(init)   # type: ignore[attr-defined]
        cls.__init__ = __init__   # type: ignore[method-assign]
        cls._flat_names = dict(renames)   # type: ignore[attr-defined]
        return cls
    return wrap
