"""Render the HTML report of a session from its stored results.

One self-contained HTML file per page (inline CSS and SVG, no script, no network: a
Content-Security-Policy meta tag forbids every external load): ``index.html`` for the session,
``worker-<id>.html`` per worker and ``print.html`` (the print version: one summary page, then at
most two A4 pages per worker), next to ``results/`` in the report folder. Templates are
Jinja2 files in templates/ (found with ergopose.resources.resource_dir) with autoescaping on and
StrictUndefined; each is fed one frozen context dataclass (ergopose.report.page_types, built by ergopose.report.pages).

Every page is rendered in memory first; only when all pages rendered are they written, each
atomically (ergopose.atomic.write_text), so a failure never leaves a half-written page and never
replaces a good page by a broken one.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jinja2

from ergopose.atomic import readable, write_text
from ergopose.errors import ErgoposeError
from ergopose.progress import ProgressCallback, report
from ergopose.report.pages import (
    PRINT_FILE,
    IndexPage,
    PrintPage,
    WorkerPage,
    build_index_page,
    build_print_page,
    build_worker_page,
    worker_page_name,
)
from ergopose.report.results import SessionResults, load_results
from ergopose.resources import resource_dir

#: Template file of each page context.
TEMPLATES: dict[type, str] = {IndexPage: "index.html.j2", WorkerPage: "worker.html.j2", PrintPage: "print.html.j2"}
INDEX_FILE = "index.html"


def environment(
    template_dir: str | os.PathLike[str] | None = None, env_class: type[jinja2.Environment] = jinja2.Environment
) -> jinja2.Environment:
    """The Jinja2 environment of the reports: autoescape on, undefined names are errors."""
    folder = Path(template_dir) if template_dir is not None else resource_dir("templates")
    return env_class(
        loader=jinja2.FileSystemLoader(str(folder)),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def context_variables(context: Any) -> dict[str, Any]:
    """A page context's fields as template variables (the template sees exactly these names)."""
    return {f.name: getattr(context, f.name) for f in dataclasses.fields(context)}


def render_page(context: IndexPage | WorkerPage | PrintPage, env: jinja2.Environment | None = None) -> str:
    """HTML of one page from its context."""
    env = env or environment()
    try:
        template = env.get_template(TEMPLATES[type(context)])
    except jinja2.TemplateNotFound as exc:
        raise ErgoposeError(f"report template {exc.name} is missing; reinstall ergopose") from None
    return template.render(**context_variables(context))


@dataclass(frozen=True)
class ReportFiles:
    """What render_report wrote: index (path), workers (paths, session order), sizes (bytes per path)."""

    index: Path
    workers: tuple[Path, ...]
    sizes: dict[str, int]


def render_pages(
    results: SessionResults, report_dir: str | os.PathLike[str] | None = None, progress: ProgressCallback | None = None
) -> dict[str, str]:
    """Every page of a report as {file name: HTML}, nothing written."""
    folder = Path(report_dir) if report_dir is not None else None
    env = environment()
    n = len(results.workers) + 2
    pages: dict[str, str] = {}
    report(progress, "report", 0, n, unit="page")
    for k, res in enumerate(results.workers, start=1):
        pages[worker_page_name(res.info.worker_id)] = render_page(build_worker_page(res, results.session, folder), env)
        report(progress, "report", k, n, unit="page")
    pages[PRINT_FILE] = render_page(build_print_page(results.workers, results.session, folder), env)
    report(progress, "report", n - 1, n, unit="page")
    pages[INDEX_FILE] = render_page(build_index_page(results.workers, results.session, folder), env)
    report(progress, "report", n, n, unit="page")
    return pages


def render_report(
    report_dir: str | os.PathLike[str], results: SessionResults | None = None, progress: ProgressCallback | None = None
) -> ReportFiles:
    """Render the report of ``report_dir`` from its stored results (read from ``report_dir/results``
    unless given) and write the pages there; return what was written."""
    folder = Path(report_dir)
    if results is None:
        results = load_results(folder)
    pages = render_pages(results, folder, progress)
    sizes = {}
    for name, html in pages.items():
        write_text(folder / name, html)
        readable(folder / name)
        sizes[name] = len(html.encode("utf-8"))
    return ReportFiles(
        index=folder / INDEX_FILE,
        workers=tuple(folder / worker_page_name(w.info.worker_id) for w in results.workers),
        sizes=sizes,
    )
