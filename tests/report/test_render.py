"""Rendered pages: self-contained, the right numbers, hostile names escaped everywhere."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from html.parser import HTMLParser

import markupsafe
import numpy as np
import pytest

from ergopose.report.pages import worker_page_name
from ergopose.report.render import render_report
from ergopose.report.results import save_results

from conftest import HOSTILE_NAMES
from report_synthetic import synthetic_session


class Page(HTMLParser):
    """Collects tags with attributes, text, and the share cells of the headline tables."""

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict]] = []
        self.text: list[str] = []
        self.shares: dict[str, str] = {}
        self._share: str | None = None
        self.title = ""
        self._in_title = False
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append((tag, a))
        self._share = a.get("data-share")
        self._in_title = tag == "title" and len([t for t, _ in self.tags if t == "title"]) == 1
        if self._share:
            self.shares[self._share] = ""

    def handle_endtag(self, tag):
        if tag == "td":
            self._share = None
        if tag == "title":
            self._in_title = False

    def handle_data(self, data):
        self.text.append(data)
        if self._share:
            self.shares[self._share] += data
        if self._in_title and not self.title:
            self.title = data


def expected_shares(frames, method_col, levels):
    """Share of tracked frames at each level, computed here from the per-frame table."""
    lv = frames[method_col].to_numpy(dtype=np.float64, na_value=np.nan)
    return {k: f"{100.0 * np.sum(lv == k) / len(lv):.1f} %" for k in levels}


@pytest.mark.slow
def test_headline_numbers_come_from_the_frames(rendered_report):
    folder, session, workers, files = rendered_report
    for info, (_, _, frames) in zip(session.workers, workers):
        page = Page((folder / worker_page_name(info.worker_id)).read_text(encoding="utf-8"))
        for method, col, levels in (
            ("rula", "rula_action_level", range(1, 5)),
            ("reba", "reba_risk_level", range(0, 5)),
        ):
            for k, share in expected_shares(frames, col, levels).items():
                assert page.shares[f"{method}-{k}"] == share, (info.worker_id, method, k)


@pytest.mark.slow
def test_the_sessions_notices_stand_under_every_pages_header(rendered_report):
    folder, session, _, _ = rendered_report
    assert session.notices
    pages = ["index.html", "print.html"] + [worker_page_name(w.worker_id) for w in session.workers]
    for name in pages:
        text = (folder / name).read_text(encoding="utf-8")
        header = text[text.index('<header class="page">') : text.index("</header>")]
        for notice in session.notices:
            assert "Before reading the figures:</strong> " + str(markupsafe.escape(notice)) in header, name


@pytest.mark.slow
def test_pages_are_self_contained_and_small(rendered_report):
    folder, session, workers, files = rendered_report
    assert set(files.sizes) == {"index.html", "print.html"} | {worker_page_name(w.worker_id) for w in session.workers}
    for name, size in files.sizes.items():
        text = (folder / name).read_text(encoding="utf-8")
        assert len(text.encode()) == size < 3_000_000
        page = Page(text)
        tags = {t for t, _ in page.tags}
        assert not tags & {"script", "img", "iframe", "object", "embed", "link", "video", "audio", "source"}, name
        for tag, attrs in page.tags:
            assert not any(k.startswith("on") for k in attrs), (name, tag, attrs)
            assert "src" not in attrs, (name, tag)
            href = attrs.get("href")
            if href is not None:
                assert href.startswith("#") or not re.match(r"^[a-z][a-z0-9+.-]*:", href), (name, href)
        # the only absolute URL is the SVG namespace; url() only to in-page patterns/clips
        assert set(re.findall(r"https?://[^\s\"'<>]+", text)) <= {"http://www.w3.org/2000/svg"}, name
        assert all(u.startswith("#") for u in re.findall(r"url\(([^)]*)\)", text)), name
        assert "@import" not in text and "@font-face" not in text
        assert "default-src 'none'" in text  # the CSP meta: nothing may load even if something slipped in
    assert not list(folder.glob(".*.tmp*")), "temporary files left behind"


@pytest.mark.slow
def test_every_figure_is_accessible(rendered_report):
    folder, session, workers, files = rendered_report
    for name in files.sizes:
        text = (folder / name).read_text(encoding="utf-8")
        figures = re.findall(r"<figure id=\"[^\"]+\">(.*?)</figure>", text, flags=re.S)
        assert figures, name
        for fig in figures:
            assert "<figcaption>" in fig
            svg_text = fig[fig.index("<svg") : fig.rindex("</svg>") + 6]
            root = ET.fromstring(svg_text)
            assert root.get("role") == "img" and root.get("aria-labelledby")
            ns = "{http://www.w3.org/2000/svg}"
            assert root.find(f"{ns}title").text and root.find(f"{ns}desc").text


@pytest.mark.slow
def test_links_point_at_the_csv_files(rendered_report):
    folder, session, workers, files = rendered_report
    page = Page((folder / "worker-W1.html").read_text(encoding="utf-8"))
    hrefs = [a.get("href") for t, a in page.tags if t == "a"]
    assert {"csv/W1.csv", "csv/W1-summary.csv"} <= set(hrefs) and (folder / "csv" / "W1.csv").is_file()
    assert "worker-W2.html" in hrefs and "index.html" in hrefs
    # the session summary CSV was not written in this folder: named as missing, not linked
    assert "csv/session-summary.csv" not in hrefs
    assert "missing: expected csv/session-summary.csv next to this report" in "".join(page.text)
    index = Page((folder / "index.html").read_text(encoding="utf-8"))
    assert {"worker-W1.html", "worker-W2.html", "worker-W3.html", "csv/W3.csv"} <= {
        a.get("href") for t, a in index.tags if t == "a"
    }


@pytest.mark.slow
def test_pseudonymous_ids_unless_named(rendered_report):
    folder, session, workers, files = rendered_report
    w1 = Page((folder / "worker-W1.html").read_text(encoding="utf-8"))
    w2 = Page((folder / "worker-W2.html").read_text(encoding="utf-8"))
    assert w1.title.startswith("W1:")
    assert w2.title.startswith("Anna Šimková (W2):")
    assert "Anna" not in "".join(w1.text).replace("Anna Šimková (W2)", "")  # only in W1's link to W2


@pytest.fixture(scope="module")
def hostile_report(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hostile") / "report"
    session, workers = synthetic_session(n_workers=3, duration_s=1200.0, names=HOSTILE_NAMES, seed=11)
    save_results(folder, session, workers)
    render_report(folder)
    return folder


@pytest.mark.slow
@pytest.mark.parametrize(
    "page_name", ["index.html", "print.html", "worker-W1.html", "worker-W2.html", "worker-W3.html"]
)
def test_hostile_names_are_escaped_everywhere(hostile_report, page_name):
    text = (hostile_report / page_name).read_text(encoding="utf-8")
    page = Page(text)
    assert not any(t in ("script", "img") for t, _ in page.tags)
    assert not any(k.startswith("on") for _, a in page.tags for k in a)
    for name in HOSTILE_NAMES.values():
        assert name not in text  # never verbatim
        assert str(markupsafe.escape(name)) in text
    # the names arrive intact as text (in headings, links, captions, SVG titles)
    joined = "".join(page.text)
    for wid, name in HOSTILE_NAMES.items():  # every page names every worker (heading, links or table)
        assert f"{name} ({wid})" in joined
    assert "{{ 7*7 }}" in joined  # data, never evaluated as a template
    # every inline SVG still parses as one element: no name closed it early
    for svg_text in re.findall(r"<svg .*?</svg>", text, flags=re.S):
        ET.fromstring(svg_text)
    n_open = len(re.findall(r"<svg\b", text))
    n_close = text.count("</svg>")
    assert n_open == n_close == len(re.findall(r"<figure id=", text))


@pytest.mark.slow
def test_own_page_title_holds_the_hostile_name(hostile_report):
    page = Page((hostile_report / "worker-W3.html").read_text(encoding="utf-8"))
    assert page.title.startswith(HOSTILE_NAMES["W3"] + " (W3):")


@pytest.mark.slow
def test_pages_and_results_are_readable_by_others(rendered_report):
    """Reports live on shared drives: files get the umask's permissions, not the private 0600 of
    temporary files."""
    import os
    import stat

    folder, session, workers, files = rendered_report
    mask = os.umask(0)
    os.umask(mask)
    for p in [
        files.index,
        *files.workers,
        folder / "results",
        folder / "results" / "session.json",
        folder / "results" / "workers" / "W1" / "frames.parquet",
    ]:
        mode = stat.S_IMODE(p.stat().st_mode)
        assert mode == (0o777 if p.is_dir() else 0o666) & ~mask, (p, oct(mode))


def test_short_times_and_ticks():
    from ergopose.report.timelines import _time_ticks
    from ergopose.report.wording import Clock, fmt_duration

    assert fmt_duration(0.4) == "0.4 s" and fmt_duration(0) == "0 s" and fmt_duration(59.6) == "1 min 00 s"
    assert fmt_duration(7260) == "2 h 01 min"
    ticks = _time_ticks(60.0, Clock("2024-03-04T08:00:00"))
    assert [label for _, label in ticks] == [
        "08:00:00",
        "08:00:10",
        "08:00:20",
        "08:00:30",
        "08:00:40",
        "08:00:50",
        "08:01:00",
    ]
    ticks = _time_ticks(8 * 3600.0, Clock("2024-03-04T07:45:00"))
    assert ticks[0] == (900.0, "08:00") and ticks[-1][1] == "15:00"


def _visible_text(html: str) -> str:
    """The page's text without the glossary, tags and SVG tooltips (what a reader reads as body)."""
    html = re.sub(r'<dl class="glossary">.*?</dl>', " ", html, flags=re.S)
    html = re.sub(r"<(title|desc|style)[^>]*>.*?</\1>", " ", html, flags=re.S)
    return markupsafe.Markup(re.sub(r"<[^>]+>", " ", html)).unescape()


@pytest.mark.slow
def test_no_report_defects_and_every_abbreviation_in_the_glossary(crowded_report):
    """Issue 15's defects are gone on a short, crowded session; each abbreviation the pages use is
    explained in the page's glossary."""
    folder, session, workers, files = crowded_report
    for name in files.sizes:
        html = (folder / name).read_text(encoding="utf-8")
        text = _visible_text(html)
        for bad in ("0.0 to 0.0", "n/s", "± 0.0", "(n = 1)"):
            assert bad not in html, (name, bad)
        terms = " ".join(
            re.findall(r"<dt>(.*?)</dt>", re.search(r'<dl class="glossary">(.*?)</dl>', html, flags=re.S).group(1))
        )
        for abbr in ("RULA", "REBA", "AL1", "AL2", "AL3", "AL4", "SD", "n/a", "deg"):
            if re.search(rf"(?<![\w/]){re.escape(abbr)}(?![\w/])", text):
                assert abbr in terms, (name, abbr)
    # a 10-minute shift: the hour table has times, not rows of zeros
    page = (folder / worker_page_name("W2")).read_text(encoding="utf-8")
    table = re.search(r"<caption>RULA: time at each action level per hour.*?</table>", page, flags=re.S).group(0)
    cells = re.findall(r'<td class="num">([^<]*)</td>', table)
    assert (
        cells and any(re.search(r"\d+ (s|min)", c) for c in cells) and not any(c.strip() in ("0.0", "0") for c in cells)
    )


@pytest.mark.slow
def test_pages_show_the_sustained_periods(rendered_report):
    """Each worker page lists its stored periods in order, with clock times, durations of at least
    the minimum and the body parts; the timeline marks each."""
    from ergopose.report.periods import MIN_DURATION_S
    from ergopose.report.wording import Clock, fmt_duration

    folder, session, workers, files = rendered_report
    clock = Clock(session.start)
    for info, (summary, _, _) in zip(session.workers, workers):
        html = (folder / worker_page_name(info.worker_id)).read_text(encoding="utf-8")
        rows = re.findall(r'<tr data-period="(\d+)">(.*?)</tr>', html, flags=re.S)
        assert [int(k) for k, _ in rows] == list(range(1, len(summary.worst) + 1)) and rows
        for (_, row), w in zip(rows, summary.worst):
            assert w.end_s - w.start_s >= MIN_DURATION_S
            assert clock(w.start_s) in row and clock(w.end_s) in row and fmt_duration(w.high_s) in row
            assert w.drivers[0].body_part in row
        assert len(re.findall(r'<article class="moment" data-period=', html)) == len(summary.worst)
        # the periods' share of all the high-risk time, counted here from the frames
        _, _, frames = workers[session.workers.index(info)]
        high = (frames["rula_action_level"].isin([3, 4]) | frames["reba_risk_level"].isin([3, 4])).sum() / session.fps
        held = sum(w.high_s for w in summary.worst)
        assert (
            markupsafe.escape(
                f"hold {fmt_duration(held)} of the worker's {fmt_duration(high)} at high risk "
                f"({100 * held / high:.1f} %)"
            )
            in html
        )
