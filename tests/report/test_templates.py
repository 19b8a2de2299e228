"""Each template is held to its context's documentation.

For every page template: rendered with StrictUndefined from a fully populated example context
(the synthetic session, where every optional part is present and every conditional branch has
both cases somewhere), (1) every field of every context dataclass reachable from the page context
is read by the template, (2) the template reads no attribute that is not a documented field and no
top-level name other than the context's fields, and (3) every field is named in its class
docstring (the documentation).
"""

from __future__ import annotations

import dataclasses
import re
import typing
from pathlib import Path

import jinja2
import jinja2.meta
import jinja2.nodes
import jinja2.runtime
import pytest

from ergopose.report import pages
from ergopose.report.render import TEMPLATES, context_variables, environment
from ergopose.resources import resource_dir


class RecordingContext(jinja2.runtime.Context):
    """Records the top-level names a template resolves."""

    def resolve_or_missing(self, key):
        self.environment.names.add(key)
        return super().resolve_or_missing(key)


class RecordingEnvironment(jinja2.Environment):
    """Records every attribute a template reads from a dataclass; refuses undocumented ones."""

    context_class = RecordingContext

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.reads: set[tuple[type, str]] = set()
        self.names: set[str] = set()

    def getattr(self, obj, attribute):
        if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
            names = {f.name for f in dataclasses.fields(obj)}
            if attribute not in names:
                raise AssertionError(f"template reads {type(obj).__name__}.{attribute}, which is not a field")
            self.reads.add((type(obj), attribute))
        return super().getattr(obj, attribute)

    def getitem(self, obj, argument):
        if dataclasses.is_dataclass(obj) and not isinstance(obj, type) and isinstance(argument, str):
            return self.getattr(obj, argument)
        return super().getitem(obj, argument)


def reachable_dataclasses(cls: type) -> set[type]:
    """Dataclasses reachable from cls through its field type hints."""
    seen: set[type] = set()

    def walk(tp):
        if dataclasses.is_dataclass(tp) and isinstance(tp, type):
            if tp in seen:
                return
            seen.add(tp)
            for t in typing.get_type_hints(tp).values():
                walk(t)
            return
        for arg in typing.get_args(tp):
            walk(arg)

    walk(cls)
    return seen


def all_fields(cls: type) -> set[tuple[type, str]]:
    return {(c, f.name) for c in reachable_dataclasses(cls) for f in dataclasses.fields(c)}


@pytest.fixture(scope="module")
def example_contexts(stored_report):
    """Fully populated contexts: worker W2 (named) and the index of the synthetic session."""
    from ergopose.report.results import load_results

    folder, _, _ = stored_report
    results = load_results(folder)
    worker = pages.build_worker_page(results.workers[1], results.session, folder)
    index = pages.build_index_page(results.workers, results.session, folder)
    printed = pages.build_print_page(results.workers, results.session, folder)
    return {pages.WorkerPage: worker, pages.IndexPage: index, pages.PrintPage: printed}


@pytest.mark.slow
def test_example_contexts_have_both_branches(example_contexts):
    """The examples are complete: links with and without a note, optional texts non-empty."""
    worker = example_contexts[pages.WorkerPage]
    assert any(link.note for link in worker.downloads) and any(not link.note for link in worker.downloads)
    assert worker.quality.error_3d and worker.session.site and worker.quality.calibration_rows
    for name in ("holds", "repetitions", "worst", "flags", "assumptions", "body_part_rows", "hourly_tables"):
        assert getattr(worker, name), name
    printed = example_contexts[pages.PrintPage]
    assert all(w.worst for w in printed.workers) and any(w.more for w in printed.workers) is False
    assert all(ctx.session.notices for ctx in example_contexts.values())


@pytest.mark.slow
@pytest.mark.parametrize(
    "page_type", [pages.WorkerPage, pages.IndexPage, pages.PrintPage], ids=["worker", "index", "print"]
)
def test_template_uses_every_documented_field_and_nothing_else(page_type, example_contexts):
    env = environment(env_class=RecordingEnvironment)
    ctx = example_contexts[page_type]
    html = env.get_template(TEMPLATES[page_type]).render(**context_variables(ctx))
    assert html.lstrip().startswith("<!DOCTYPE html>")
    env.reads |= {(page_type, n) for n in env.names if n in {f.name for f in dataclasses.fields(page_type)}}
    expected = all_fields(page_type)
    unread = sorted(f"{c.__name__}.{n}" for c, n in expected - env.reads)
    assert not unread, f"{TEMPLATES[page_type]} never reads: {', '.join(unread)}"
    assert env.reads <= expected


@pytest.mark.parametrize(
    "page_type", [pages.WorkerPage, pages.IndexPage, pages.PrintPage], ids=["worker", "index", "print"]
)
def test_template_names_only_context_fields(page_type):
    """Top-level names of the template and of the layout it extends are exactly the context's fields."""
    env = environment()
    folder = resource_dir("templates")
    names: set[str] = set()
    for name in (TEMPLATES[page_type], "_layout.html.j2"):
        ast = env.parse((folder / name).read_text(encoding="utf-8"))
        imported = {node.target for node in ast.find_all(jinja2.nodes.Import)}  # macro modules ("ui")
        names |= jinja2.meta.find_undeclared_variables(ast) - imported
    fields = {f.name for f in dataclasses.fields(page_type)}
    assert names <= fields, f"undocumented names: {sorted(names - fields)}"
    assert fields <= names, f"fields the template never names: {sorted(fields - names)}"


def test_macros_use_only_their_arguments():
    env = environment()
    source = (resource_dir("templates") / "_macros.html.j2").read_text(encoding="utf-8")
    assert jinja2.meta.find_undeclared_variables(env.parse(source)) == set()


@pytest.mark.parametrize(
    "cls",
    sorted(
        reachable_dataclasses(pages.WorkerPage)
        | reachable_dataclasses(pages.IndexPage)
        | reachable_dataclasses(pages.PrintPage),
        key=lambda c: c.__name__,
    ),
    ids=lambda c: c.__name__,
)
def test_every_context_field_is_documented(cls):
    doc = cls.__doc__ or ""
    missing = [f.name for f in dataclasses.fields(cls) if not re.search(rf"\b{re.escape(f.name)}\b", doc)]
    assert not missing, f"{cls.__name__} does not document: {', '.join(missing)}"


@pytest.mark.slow
def test_strict_undefined_catches_a_missing_field(example_contexts):
    """A template naming something the context lacks fails loudly (StrictUndefined), not silently."""
    env = environment()
    template = env.from_string("{{ session.no_such_field }}")
    with pytest.raises(jinja2.UndefinedError):
        template.render(**context_variables(example_contexts[pages.IndexPage]))


def test_templates_are_packaged():
    """Every template file matches the package-data globs of pyproject.toml."""
    import tomllib

    root = Path(__file__).resolve().parents[2]
    globs = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"][
        "ergopose.templates"
    ]
    for f in (root / "templates").iterdir():
        assert any(f.match(g) for g in globs), f"{f.name} would not be installed"
