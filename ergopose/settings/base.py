"""The common ground of the settings tables: a strict pydantic base model, the words that say what a
key allows, and the one-line ConfigError made from a pydantic ValidationError.

Every table of settings.toml is a subclass of :class:`Table`: unknown keys are refused, values are
taken as TOML gives them (no text-to-number guessing; an integer is a number, true is not), numbers
must be finite. A field's ``description`` is its one-line explanation (template and docs), its
``examples[0]`` the value the template shows for a key without a default.
"""

from __future__ import annotations

import datetime as dt
import difflib
import os
import types
import typing
from typing import Any, Literal, Mapping, Sequence, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError
from pydantic.fields import FieldInfo

from ergopose.errors import ConfigError


class Table(BaseModel):
    """A table of settings.toml: strict types, unknown keys refused, frozen."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)

    def given(self) -> dict[str, Any]:
        """The keys the file gave (not the defaults), with their validated values."""
        return {k: getattr(self, k) for k in type(self).model_fields if k in self.model_fields_set}


T = TypeVar("T", bound=Table)

#: The unit a key's name ends with, as the messages and the docs say it.
UNITS = (
    ("_deg_s", "degrees per second"),
    ("_deg", "degrees"),
    ("_m_per_s", "metres per second"),
    ("_m_s2", "metres per second squared"),
    ("_m_s", "metres per second"),
    ("_m", "metres"),
    ("_s", "seconds"),
    ("_kg", "kilograms"),
    ("_px", "pixels"),
    ("_per_min", "per minute"),
)


def unit_of(name: str) -> str | None:
    for suffix, unit in UNITS:
        if name.endswith(suffix):
            return unit
    return None


def _num(x: Any) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def _range(metadata: Sequence[Any]) -> str:
    """The bounds of pydantic's constraint metadata (annotated_types Ge / Gt / Le / Lt) in words."""
    lo = hi = None
    for m in metadata:
        if getattr(m, "ge", None) is not None:
            lo = f">= {_num(m.ge)}", m.ge, True
        elif getattr(m, "gt", None) is not None:
            lo = f"greater than {_num(m.gt)}", m.gt, False
        elif getattr(m, "le", None) is not None:
            hi = f"<= {_num(m.le)}", m.le, True
        elif getattr(m, "lt", None) is not None:
            hi = f"below {_num(m.lt)}", m.lt, False
    if lo and hi and lo[2] and hi[2]:
        return f" from {_num(lo[1])} to {_num(hi[1])}"
    return "".join(f" {p[0]}" if k == 0 else f" and {p[0]}" for k, p in enumerate(x for x in (lo, hi) if x))


def _strip_optional(annotation: Any) -> Any:
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(args) == 1:
            return args[0]
    return annotation


def allowed(annotation: Any, field: FieldInfo | None = None, name: str = "") -> str:
    """What a key accepts, in words ("a number from -90 to 90 (degrees)", "one of good, fair")."""
    extra = field.json_schema_extra if field is not None and isinstance(field.json_schema_extra, dict) else {}
    if extra.get("allowed"):
        return str(extra["allowed"])
    annotation = _strip_optional(annotation)
    metadata = list(field.metadata) if field is not None else []
    if typing.get_origin(annotation) is typing.Annotated:
        args = typing.get_args(annotation)
        annotation, metadata = args[0], metadata + list(args[1:])
    unit = unit_of(name)
    unit_text = f" ({unit})" if unit else ""
    origin = typing.get_origin(annotation)
    if annotation is bool:
        return "true or false"
    if origin is Literal:
        return "one of " + ", ".join(str(a) for a in typing.get_args(annotation))
    if annotation is int:
        return f"a whole number{_range(metadata)}{unit_text}"
    if annotation is float:
        return f"a number{_range(metadata)}{unit_text}"
    if annotation is str:
        return "a non-empty text"
    if annotation is dt.datetime:
        return "an ISO 8601 date and time (e.g. 2024-03-04T08:00:00+01:00)"
    if isinstance(annotation, type) and issubclass(annotation, Table):
        return f"a table ({', '.join(annotation.model_fields)})"
    if origin in (list, tuple):
        inner = typing.get_args(annotation)[0]
        if isinstance(inner, type) and issubclass(inner, Table):
            return f"a list of tables ({', '.join(inner.model_fields)})"
        return f"a list, each {allowed(inner, None, name)}"
    if origin is dict:
        inner = typing.get_args(annotation)[1]
        return f"tables, one per id ({', '.join(inner.model_fields)})"
    return str(annotation)


def _walk(model: type[Table], loc: Sequence[Any]) -> tuple[int, type[Table] | None, str, FieldInfo | None, Any]:
    """Walk a model along an error location: (parts of ``loc`` that are keys or list places, the
    table of the last key, that key, its FieldInfo (None for an unknown key), the annotation of the
    value there). A union member's tag or a place inside a value ends the walk."""
    table: type[Table] | None = None
    annotation: Any = model
    key, info, used = "", None, 0
    for part in loc:
        annotation = _strip_optional(annotation)
        origin = typing.get_origin(annotation)
        if isinstance(annotation, type) and issubclass(annotation, Table) and isinstance(part, str):
            table, key, info = annotation, part, annotation.model_fields.get(part)
            used += 1
            if info is None:
                return used, table, key, None, None
            annotation = info.annotation
        elif origin in (list, tuple) and isinstance(part, int):
            annotation, used = typing.get_args(annotation)[0], used + 1
        elif origin is dict:
            annotation, used = typing.get_args(annotation)[1], used + 1
        else:
            break
    return used, table, key, info, annotation


def key_path(loc: Sequence[Any], prefix: Sequence[Any] = ()) -> str:
    """``('workers', 'w1', 'periods', 0, 'load_kg')`` -> ``workers.w1.periods[0].load_kg``."""
    out = ""
    for part in (*prefix, *loc):
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def _message(model: type[Table], err: Mapping[str, Any]) -> tuple[tuple[Any, ...], str]:
    used, table, key, info, annotation = _walk(model, tuple(err["loc"]))
    loc = tuple(err["loc"])[:used]
    kind = err["type"]
    if kind == "extra_forbidden":
        known = list(table.model_fields) if table is not None else []
        close = difflib.get_close_matches(str(key), known, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else f" (allowed: {', '.join(known)})"
        return loc, f"unknown key{hint}"
    if kind in ("value_error", "assertion_error", "ergopose"):
        text = str(err["msg"])
        for prefix in ("Value error, ", "Assertion failed, "):
            text = text.removeprefix(prefix)
        return loc, text
    what = allowed(annotation, info, str(key)) if annotation is not None else "something else"
    if kind == "missing":
        return loc, f"missing; expected {what}"
    return loc, f"expected {what}, got {err['input']!r}"


def config_error(
    model: type[Table], exc: ValidationError, path: str | os.PathLike[str] | None, prefix: Sequence[Any] = ()
) -> ConfigError:
    """ONE ConfigError for a ValidationError: the file, the key path, the value and what is allowed
    (and how many more problems the file has)."""
    # an unknown key first: a misspelt key is the likeliest cause of the other problems
    errors = sorted(exc.errors(include_url=False), key=lambda e: e["type"] != "extra_forbidden")
    loc, text = _message(model, errors[0])
    others = list(dict.fromkeys(key_path(_message(model, e)[0], prefix) or "(top)" for e in errors[1:]))
    if others:
        shown = ", ".join(others[:3]) + (", ..." if len(others) > 3 else "")
        text += f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''}: {shown})"
    return ConfigError(text, path=path, field=key_path(loc, prefix) or None)


def validate(model: type[T], data: Any, path: str | os.PathLike[str] | None = None, prefix: Sequence[Any] = ()) -> T:
    """``data`` (a dict from TOML) as a ``model``; any problem raises one ConfigError naming ``path``
    and the key path (under ``prefix``, e.g. ``("scoring",)`` for a table of a larger file)."""
    if not isinstance(data, dict):
        raise ConfigError(f"expected {allowed(model)}, got {data!r}", path=path, field=key_path(prefix) or None)
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise config_error(model, exc, path, prefix) from None
