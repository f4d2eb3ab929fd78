"""Settings dataclasses as TOML tables and back, with typed reading.

:func:`from_dict` builds a (nested) frozen settings dataclass from a table read from a file: every
value is checked against its field's type hint before the class sees it (an integer is a whole
number, not a boolean or 2.5; a float a finite number; a boolean ``true``/``false``; a tuple a list
of the right length), unknown keys are refused with the allowed ones, a table where a value is
due (or the reverse) is refused by name, and old flat names are read with a ``FutureWarning``
(:func:`dexpush.common.settings.upgrade_flat`). TOML has no null: an optional setting that is on
by default is turned off with ``"off"``; one that is unset by default is left out.
:func:`to_toml` writes the text that reads back to the same settings.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from dataclasses import fields, is_dataclass
from typing import Any

from dexpush.common.settings import upgrade_flat

__all__ = ["from_dict", "merge", "to_dict", "to_toml"]

#: the largest whole number a setting takes (samples, steps, seeds): beyond it nothing fits in memory or time
MAX_WHOLE = 2**32
_OFF = ("off", "none")


def to_dict(obj: Any, skip: frozenset[tuple[str, str]] = frozenset(), where: str = "") -> Any:
    """A settings dataclass as nested dicts (tuples as lists), without the (table, key) pairs in ``skip``."""
    if is_dataclass(obj):
        return {f.name: to_dict(getattr(obj, f.name), skip, f.name) for f in fields(obj)
                if (where, f.name) not in skip}
    if isinstance(obj, tuple | list):
        return [to_dict(v, skip) for v in obj]
    return obj


def merge(base: dict, over: dict) -> dict:
    """``base`` with ``over``'s keys on top, nested tables merged."""
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, dict) and k in out and not isinstance(out[k], dict):
            raise ValueError(f"[{k}] must be a table of settings, got {out[k]!r}")
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _kinds(hint: Any) -> tuple[Any, ...]:
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return typing.get_args(hint)
    return (hint,)


def _typed(value: Any, hint: Any, where: str) -> Any:
    """``value`` as the type ``hint`` asks for, or a ``ValueError`` naming ``where``."""
    kinds = _kinds(hint)
    if type(None) in kinds:
        if value is None or (isinstance(value, str) and value.strip().lower() in _OFF):
            return None
        kinds = tuple(k for k in kinds if k is not type(None))
    errors = []
    for kind in kinds:
        try:
            return _one(value, kind, where)
        except ValueError as exc:
            errors.append(str(exc))
    raise ValueError(errors[0] if len(errors) == 1 else f"{where} must be one of: " + "; or ".join(
        e.split(" must be ", 1)[-1] for e in errors))


def _one(value: Any, kind: Any, where: str) -> Any:
    origin = typing.get_origin(kind)
    if kind is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{where} must be true or false, got {value!r}")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) \
                or int(value) != value or abs(value) > MAX_WHOLE:
            raise ValueError(f"{where} must be a whole number, got {value!r}")
        return int(value)
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise ValueError(f"{where} must be a finite number, got {value!r}")
        return float(value)
    if kind is str:
        if not isinstance(value, str):
            raise ValueError(f"{where} must be a string, got {value!r}")
        return value
    if origin is tuple:
        args = typing.get_args(kind)
        if not isinstance(value, list | tuple):
            raise ValueError(f"{where} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_typed(v, args[0], f"{where}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ValueError(f"{where} must be a list of {len(args)}, got {value!r}")
        return tuple(_typed(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
    return value


def from_dict(cls: type, data: Any, where: str, skip: frozenset[tuple[str, str]] = frozenset()) -> Any:
    """``cls(**data)`` with nested settings tables and typed values (see the module docstring)."""
    if not isinstance(data, dict):
        raise ValueError(f"[{where}] must be a table of settings, got {data!r}")
    data = upgrade_flat(cls, data, f"[{where}]")
    hints = typing.get_type_hints(cls)
    table = where.rsplit(".", 1)[-1]
    known = {f.name: f for f in fields(cls) if f.init and (table, f.name) not in skip}
    unknown = sorted(set(data) - set(known))
    if unknown:
        raise ValueError(f"unknown key {unknown[0]!r} in [{where}]; allowed: {', '.join(known)}")
    kwargs = {}
    for name, value in data.items():
        sub = next((k for k in _kinds(hints[name]) if isinstance(k, type) and is_dataclass(k)), None)
        inner = f"{where}.{name}" if where != "config" else name
        if sub is not None:
            kwargs[name] = from_dict(sub, value, inner, skip)
        elif isinstance(value, dict):
            raise ValueError(f"[{where}] {name} is a setting, not a table")
        else:
            kwargs[name] = _typed(value, hints[name], f"[{where}] {name}")
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise ValueError(f"[{where}]: {exc}") from None


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf" if v < 0 else "nan")
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise ValueError(f"cannot write {v!r} as TOML")


def to_toml(obj: Any, header: str, skip: frozenset[tuple[str, str]] = frozenset(),
            tables: tuple[str, ...] | None = None) -> str:
    """The settings dataclass ``obj`` (whose fields are settings tables) as TOML text that
    :func:`from_dict` reads back to the same settings; only ``tables`` when given."""
    lines: list[str] = [f"# {header}"]

    def table(name: str, value: Any, where: str) -> None:
        lines.append(f"\n[{name}]")
        nested = []
        for f in fields(value):
            if (where, f.name) in skip:
                continue
            v = getattr(value, f.name)
            if is_dataclass(v):
                nested.append((f.name, v))
            elif v is None:
                default = f.default if f.default is not dataclasses.MISSING else None
                lines.append(f"# {f.name} = ...   (unset: the default applies)" if default is None
                             else f'{f.name} = "off"')
            else:
                lines.append(f"{f.name} = {_toml_value(to_dict(v))}")
        for k, v in nested:
            table(f"{name}.{k}", v, k)

    for f in fields(obj):
        if tables is None or f.name in tables:
            table(f.name, getattr(obj, f.name), f.name)
    return "\n".join(lines) + "\n"
