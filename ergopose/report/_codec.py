"""Frozen dataclasses to and from JSON, checked against their type hints.

Supported field types: bool, int, float, str, None unions (``X | None``), ``tuple[X, ...]``,
``tuple[X, Y]``, ``dict[str, X]`` and nested dataclasses. A float NaN is written as JSON null
and read back as NaN (for a ``float`` field); ``float | None`` keeps null as None. Reading names
the file and the dotted field of the first value that does not fit, as an InputError.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any

from ergopose.errors import InputError


def to_jsonable(obj: Any) -> Any:
    """A dataclass tree as plain JSON values (NaN/inf floats become None)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (tuple, list)):
        return [to_jsonable(v) for v in obj]
    if hasattr(obj, "item"):  # numpy scalar
        return to_jsonable(obj.item())
    raise TypeError(f"cannot write {type(obj).__name__} as JSON")


_HINTS: dict[type, dict[str, Any]] = {}


def _hints(cls: type) -> dict[str, Any]:
    if cls not in _HINTS:
        _HINTS[cls] = typing.get_type_hints(cls)
    return _HINTS[cls]


def from_jsonable(tp: Any, data: Any, *, source: str, field: str = "") -> Any:
    """Build a value of type ``tp`` from JSON data; raise InputError naming source and field."""

    def bad(what: str) -> InputError:
        return InputError(f"{what}, got {_short(data)}", path=source, field=field or "(top level)")

    origin = typing.get_origin(tp)
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):  # a dataclass type (not an instance)
        if not isinstance(data, dict):
            raise bad(f"expected an object ({tp.__name__})")
        hints = _hints(tp)
        names = {f.name for f in dataclasses.fields(tp)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise InputError(
                f"unknown field(s) {', '.join(unknown)} in {tp.__name__}", path=source, field=field or "(top level)"
            )
        kwargs: dict[str, Any] = {}
        for f in dataclasses.fields(tp):
            sub = f"{field}.{f.name}" if field else f.name
            if f.name not in data:
                if f.default is not dataclasses.MISSING:
                    kwargs[f.name] = f.default
                    continue
                if f.default_factory is not dataclasses.MISSING:
                    kwargs[f.name] = f.default_factory()
                    continue
                raise InputError(f"missing field ({tp.__name__})", path=source, field=sub)
            kwargs[f.name] = from_jsonable(hints[f.name], data[f.name], source=source, field=sub)
        try:
            return tp(**kwargs)
        except (ValueError, TypeError) as exc:
            raise InputError(f"invalid {tp.__name__}: {exc}", path=source, field=field or "(top level)") from None
    if origin in (typing.Union, types.UnionType):
        args = typing.get_args(tp)
        if data is None and type(None) in args:
            return None
        for a in args:
            if a is type(None):
                continue
            try:
                return from_jsonable(a, data, source=source, field=field)
            except InputError:
                if len(args) == 2:
                    raise
        raise bad(f"expected {tp}")
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(data, list):
            raise bad("expected a list")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(from_jsonable(args[0], v, source=source, field=f"{field}[{i}]") for i, v in enumerate(data))
        if len(data) != len(args):
            raise bad(f"expected a list of {len(args)} values")
        return tuple(
            from_jsonable(a, v, source=source, field=f"{field}[{i}]") for i, (a, v) in enumerate(zip(args, data))
        )
    if origin is dict or origin is typing.Mapping or str(origin) == "<class 'collections.abc.Mapping'>":
        _, vt = typing.get_args(tp)
        if not isinstance(data, dict):
            raise bad("expected an object")
        return {str(k): from_jsonable(vt, v, source=source, field=f"{field}.{k}") for k, v in data.items()}
    if tp is float:
        if data is None:
            return math.nan
        if isinstance(data, bool) or not isinstance(data, (int, float)):
            raise bad("expected a number")
        return float(data)
    if tp is int:
        if isinstance(data, bool) or not isinstance(data, int):
            raise bad("expected an integer")
        return int(data)
    if tp is bool:
        if not isinstance(data, bool):
            raise bad("expected true or false")
        return data
    if tp is str:
        if not isinstance(data, str):
            raise bad("expected a string")
        return data
    if tp is typing.Any:
        return data
    raise TypeError(f"unsupported field type {tp!r}")


def _short(data: Any) -> str:
    text = repr(data)
    return text if len(text) <= 60 else text[:57] + "..."
