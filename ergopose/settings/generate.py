"""What the settings model writes: settings.toml text (the template, and every settings file
ergopose writes) and docs/settings.md.

Both walk :class:`ergopose.settings.model.SettingsFile`, so a key added to the model appears in
the template and the docs at once (tests/settings/test_settings_generate.py fails when
docs/settings.md is not what :func:`settings_markdown` gives; ``make settings-docs`` writes it).
"""

from __future__ import annotations

import datetime as dt
import types
import typing
from typing import Any, Iterable

import tomli_w
from pydantic.fields import FieldInfo

from ergopose.settings.base import Table, allowed
from ergopose.settings.model import FORMAT_VERSION, SettingsFile
from ergopose.settings.tasks import TaskFactorsTable

#: How to read the commented keys (every settings.toml ergopose writes says it).
TEMPLATE_HOWTO = """\
# A key written as a comment ('# key = value') is not set: it shows the default, or an example
# where there is no default. Remove the leading '# ' (of the [table] line too) to set it.
"""
TEMPLATE_HEADER = (
    "# ergopose session settings (docs/session-format.md explains the file, docs/settings.md lists "
    "every key).\n" + TEMPLATE_HOWTO
)

#: Example values of the keys the template must set.
EXAMPLE_REQUIRED: dict[str, Any] = {
    "format_version": FORMAT_VERSION,
    "recorded_at": dt.datetime(2024, 3, 4, 8, 0, tzinfo=dt.timezone(dt.timedelta(hours=1))),
    "cameras": [{"name": "cam_1", "video": "cam_1.mp4"}, {"name": "cam_2", "video": "cam_2.mp4"}],
}


def _kind(annotation: Any) -> tuple[str, type[Table] | None]:
    """("table" | "tables" | "named" | "value", the table class)."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(args) == 1:
            annotation = args[0]
    origin = typing.get_origin(annotation)
    if isinstance(annotation, type) and issubclass(annotation, Table):
        return "table", annotation
    if origin is list and _is_table(typing.get_args(annotation)[0]):
        return "tables", typing.get_args(annotation)[0]
    if origin is dict and _is_table(typing.get_args(annotation)[1]):
        return "named", typing.get_args(annotation)[1]
    return "value", None


def _is_table(x: Any) -> bool:
    return isinstance(x, type) and issubclass(x, Table)


def _own_first(cls: type[Table]) -> list[str]:
    """The fields of a table, its own before the inherited ones (a worker's name before the factors)."""
    own = [n for n in cls.model_fields if n in cls.__dict__.get("__annotations__", {})]
    return own + [n for n in cls.model_fields if n not in own]


def _inherits_factors(cls: type[Table]) -> bool:
    return cls is not TaskFactorsTable and issubclass(cls, TaskFactorsTable)


def _toml_value(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_toml_value(v) for v in value]
    return value


def _kv(key: str, value: Any) -> str:
    left = tomli_w.dumps({key: 0}).split("=")[0]
    if isinstance(value, dt.datetime):  # ISO 8601 with the 'T', as the docs write it
        return f"{left}= {value.isoformat()}"
    if isinstance(value, (list, tuple)) and not any(isinstance(v, dict) for v in value):  # on one line
        return f"{left}= [{', '.join(_kv('x', v)[4:] for v in value)}]"
    return tomli_w.dumps({key: _toml_value(value)}).rstrip("\n")


def _shown(info: FieldInfo) -> Any:
    """The value a commented key shows: its default, else its example."""
    if not info.is_required() and info.default is not None and not info.default_factory:
        return info.default
    return info.examples[0] if info.examples else None


def _explain(name: str, info: FieldInfo, factor: bool) -> str:
    what = allowed(info.annotation, info, name)
    if info.is_required():
        note = "required"
    elif info.default is None:
        note = (
            "optional, not given: unknown (the value shown is an example)"
            if factor
            else ("optional (the value shown is an example)")
        )
    else:
        note = f"default {_kv('x', _toml_value(info.default))[4:]}"
    return f"#   {info.description}; {what}; {note}"


def _table_lines(
    cls: type[Table], data: dict[str, Any] | None, header: str, active: bool, explain: bool = True
) -> list[str]:
    """One table: a header line, then each key's explanation (``explain``: the first of a list of
    tables only) and the key (set when ``data`` gives it, else commented), then its sub-tables."""
    c = "" if active else "# "
    out = [f"{c}{header}"] if header else []
    subs = []
    factors_noted = False
    for name in _own_first(cls):
        info = cls.model_fields[name]
        kind, sub = _kind(info.annotation)
        if kind != "value":
            subs.append((name, kind, sub, info))
            continue
        if _inherits_factors(cls) and name in TaskFactorsTable.model_fields:
            if not factors_noted and explain:
                out.append("#   ... and any task factor of [defaults] (load_kg, load_mode, coupling, ...)")
                factors_noted = True
            if data is not None and name in data:
                out.append(_kv(name, data[name]))
            elif name == "load_kg" and (data is None or not set(data) & set(TaskFactorsTable.model_fields)):
                out.append(f"# {_kv(name, 12.0)}")
            continue
        if explain:
            out.append(_explain(name, info, issubclass(cls, TaskFactorsTable)))
        if data is not None and name in data:
            out.append(_kv(name, data[name]))
        elif active and info.is_required():
            out.append(_kv(name, _shown(info)))
        else:
            out.append(f"# {_kv(name, _shown(info))}")
    prefix = header.strip("[]") + "." if header else ""
    for name, kind, sub, info in subs:
        assert sub is not None
        given = data.get(name) if data is not None else None
        path = f"{prefix}{name}"
        out.append("")
        if explain:
            out.append(f"# --- {path}: {info.description}")
        if kind == "table":
            out += _table_lines(sub, given, f"[{path}]", given is not None, explain)
        elif kind == "tables":
            items = given if given else [None]
            for k, item in enumerate(items):
                if k:
                    out.append("")
                out += _table_lines(sub, item, f"[[{path}]]", item is not None, explain and k == 0)
        else:  # named tables: [workers.<id>]
            named: list[tuple[str, Any]] = list(given.items()) if given else [("w1", None)]
            for k, (key, item) in enumerate(named):
                if k:
                    out.append("")
                out += _table_lines(sub, item, f"[{path}.{_toml_key(key)}]", item is not None, explain and k == 0)
    return out


def _toml_key(key: str) -> str:
    return key if key and all(ch.isalnum() or ch in "_-" for ch in key) else _kv("x", key)[4:]


def settings_text(data: dict[str, Any] | None = None, header: str = TEMPLATE_HEADER) -> str:
    """settings.toml with the keys of ``data`` set (TOML values as tomllib reads them) and every
    other key of the model commented, with its default and a one-line explanation. Without
    ``data``: the template (the required keys set to examples)."""
    given = dict(EXAMPLE_REQUIRED if data is None else data)
    lines = _table_lines(SettingsFile, given, "", True)
    text = "\n".join(lines).strip("\n") + "\n"
    return (header + "\n" if header else "") + text


# ------------------------------------------------------------------------------------- docs


def _default_cell(info: FieldInfo, in_factors: bool) -> str:
    if info.is_required():
        return "required"
    if info.default_factory is not None:
        return "none" if info.default_factory in (list, dict) else "the defaults below"
    if info.default is None:
        return "not given: unknown" if in_factors else "optional"
    return f"`{_kv('x', _toml_value(info.default))[4:]}`"


def _rows(cls: type[Table], path: str) -> Iterable[str]:
    for name in _own_first(cls):
        info = cls.model_fields[name]
        kind, sub = _kind(info.annotation)
        if _inherits_factors(cls) and name in TaskFactorsTable.model_fields:
            continue
        if kind != "value":
            what = {
                "table": f"table `[{path}{name}]`",
                "tables": f"tables `[[{path}{name}]]`",
                "named": f"tables `[{path}{name}.<id>]`",
            }[kind]
            yield f"| `{name}` | {what} | {_default_cell(info, False)} | {info.description} |"
            continue
        text = allowed(info.annotation, info, name).replace("|", "\\|")
        yield (
            f"| `{name}` | {text} | {_default_cell(info, name in TaskFactorsTable.model_fields)} | {info.description} |"
        )
    if _inherits_factors(cls):
        yield "| any task factor | as in `[defaults]` | not given: unknown | the factors of this window or worker |"


def _sections(cls: type[Table], path: str, title: str) -> list[str]:
    out = [f"## {title}", ""]
    if cls.__doc__:
        out += [" ".join(cls.__doc__.split()), ""]
    out += ["| Key | Allowed | Default | Meaning |", "|---|---|---|---|", *_rows(cls, path), ""]
    for name in _own_first(cls):
        info = cls.model_fields[name]
        kind, sub = _kind(info.annotation)
        if kind == "value" or sub is None:
            continue
        sub_path = {"table": f"{path}{name}", "tables": f"{path}{name}", "named": f"{path}{name}.<id>"}[kind]
        sub_title = {"table": f"[{sub_path}]", "tables": f"[[{sub_path}]]", "named": f"[{sub_path}]"}[kind]
        out += _sections(sub, sub_path + ".", f"`{sub_title}`")
    return out


DOCS_HEADER = """\
# settings.toml: every key

Generated from the settings model (`ergopose/settings/`) by `make settings-docs` (`python -m
ergopose.settings`); do not edit by hand (tests/settings/test_settings_generate.py fails when
this page and the model differ).
docs/session-format.md explains the file; `ergopose settings template` writes a settings.toml
with every key, its default and a one-line explanation as comments.

A problem stops with one line naming the file, the key path, the value and what is allowed:

    ergopose: error: day1/settings.toml: workers.w1.periods[0].load_kg: expected a number >= 0 (kilograms), got -2.0
    ergopose: error: day1/settings.toml: workers.w1.seatd: unknown key; did you mean 'seated'?

Units are in the key names (`_m` metres, `_s` seconds, `_deg` degrees, `_kg` kilograms, `_px`
pixels); inside, ergopose works in radians. Task factors not given are unknown, and the scoring
says so (docs/scoring.md).
"""


def settings_markdown() -> str:
    """docs/settings.md: every key of every table, with what it allows, its default and meaning."""
    lines = _sections(SettingsFile, "", "Top level")
    return DOCS_HEADER + "\n" + "\n".join(lines).rstrip("\n") + "\n"
