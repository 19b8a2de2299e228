"""Fixtures for the report tests: a seeded synthetic result set stored as ``ergopose assess``
would store it (report_synthetic.py), rendered once per test session where tests only read."""

from __future__ import annotations

import pytest

from report_synthetic import synthetic_session, write_csv_targets

#: Names a session settings file could map worker ids to, written to break out of every context
#: a name lands in: HTML text, attributes, <title>, inline SVG (<title>, <desc>, <text>), Jinja.
HOSTILE_NAMES = {
    "W1": '<script>alert("x")</script>',
    "W2": '"><img src=x onerror=alert(1)></svg><svg onload=alert(2)>',
    "W3": "Zoë O'Brien & 李雷 🙂 </title></desc></text>{{ 7*7 }}{% raw %}",
}


@pytest.fixture(scope="session")
def stored_report(tmp_path_factory):
    """A report folder with stored results of a 2-hour, 3-worker synthetic shift (W2 named)."""
    from ergopose.report.results import save_results

    folder = tmp_path_factory.mktemp("report") / "synthetic-shift"
    session, workers = synthetic_session(n_workers=3, duration_s=2 * 3600.0, names={"W2": "Anna Šimková"})
    save_results(folder, session, workers)
    write_csv_targets(folder, session, only_workers=True)
    return folder, session, workers


@pytest.fixture(scope="session")
def rendered_report(stored_report):
    """The stored report rendered (pages written next to results/)."""
    from ergopose.report.render import render_report

    folder, session, workers = stored_report
    files = render_report(folder)
    return folder, session, workers, files


#: Names that strain the layout: right-to-left (Arabic, Hebrew), very long without a break, CJK.
CROWDED_NAMES = (
    "فاطمة الزهراء بنت محمد عبد الرحمن",
    "אברהם בן־דוד הלוי מירושלים",
    "Maximilian-Alexander-Oberbergermeister-Wolkenstein-Trostburg-von-und-zu-Hohenzollern-Sigmaringen",
    "李雷",
    "Ana María de la Santísima Trinidad Fernández-Villaverde y Gómez de Arteche",
)


@pytest.fixture(scope="session")
def crowded_report(tmp_path_factory):
    """A rendered report of a 10-minute shift of 20 workers named with CROWDED_NAMES in turn."""
    from ergopose.report.render import render_report
    from ergopose.report.results import save_results

    folder = tmp_path_factory.mktemp("crowded") / "crowded-shift"
    names = {f"W{k + 1}": CROWDED_NAMES[k % len(CROWDED_NAMES)] for k in range(20)}
    session, workers = synthetic_session(n_workers=20, duration_s=600.0, names=names, seed=11)
    save_results(folder, session, workers)
    write_csv_targets(folder, session)
    files = render_report(folder)
    return folder, session, workers, files
