"""The print version and crowded pages in the real headless browser (Chromium).

- print.html prints to one summary page, then at most two A4 pages per worker: Chromium's PDF
  names a destination for each worker's section (the summary table links to it), so the pages of
  each worker are counted from the PDF's page tree.
- 20 workers with long, right-to-left and CJK names keep every page laid out: nothing wider than
  the window, names inside their boxes and marked dir="auto" (measured by a test-only script in
  a copy of each page, as in test_browser.py); print.html is measured with its print rules in
  force at the width of an A4 page's printable area.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from ergopose.report.pages import PRINT_FILE, worker_page_name
from tests.report.test_browser import console_messages, run_chromium

pytestmark = pytest.mark.browser

#: The printable width of A4 with the print version's 12 mm side margins, in CSS pixels (96/in).
A4_PRINTABLE_PX = round((210 - 24) / 25.4 * 96)

LAYOUT_PROBE = """<script>
(function () {
  var vw = document.documentElement.clientWidth, out = {viewport: vw,
      scroll_width: document.documentElement.scrollWidth, outside: [], overflowing: [], names: 0};
  function check(e, what) {
    var r = e.getBoundingClientRect();
    if (r.width > 0 && (r.left < -0.5 || r.right > vw + 0.5))
      out.outside.push(what + ': ' + e.tagName + ' ' + (e.id || e.className) + ' ' + r.left + '..' + r.right);
  }
  document.querySelectorAll('table, svg, h1, h2, h3, nav, figure, .moment').forEach(function (e) { check(e, 'box'); });
  document.querySelectorAll('[dir=auto]').forEach(function (e) {
    out.names += 1; check(e, 'name');
    var box = e.closest('th, td, h1, h2, h3, li, p');
    if (box && box.scrollWidth > box.clientWidth + 1 && getComputedStyle(box).overflow === 'visible')
      out.overflowing.push(box.tagName + ' ' + box.textContent.slice(0, 40));
  });
  var pre = document.createElement('pre');
  pre.id = 'ergopose-layout';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
})();
</script>"""


def layout(page: Path, tmp_path: Path, window: str, print_rules: bool = False) -> dict:
    """The layout probe's findings on a test-only copy of ``page`` (print rules applied on screen
    when asked)."""
    html = page.read_text(encoding="utf-8")
    csp = "default-src 'none'; style-src 'unsafe-inline'; img-src data:"
    html = html.replace(csp, csp + "; script-src 'unsafe-inline'").replace("</body>", LAYOUT_PROBE + "</body>")
    if print_rules:
        html = html.replace("@media print", "@media all")
    copy = page.with_name(f"test-layout-{page.name}")
    copy.write_text(html, encoding="utf-8")
    try:
        proc = run_chromium(copy.as_uri(), tmp_path, "--dump-dom", f"--window-size={window}")
    finally:
        copy.unlink()
    assert console_messages(proc.stderr) == []
    m = re.search(r'<pre id="ergopose-layout">(.*?)</pre>', proc.stdout, flags=re.S)
    assert m, "the probe did not run"
    return json.loads(m.group(1).replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", '"'))


def pdf_pages(page: Path, tmp_path: Path) -> tuple[int, dict[str, int]]:
    """(number of pages, {worker id: pages of its section}) of ``page`` printed to PDF by Chromium."""
    pdf = tmp_path / f"{page.stem}.pdf"
    proc = run_chromium(page.as_uri(), tmp_path, f"--print-to-pdf={pdf}", "--no-pdf-header-footer")
    assert console_messages(proc.stderr) == []
    data = pdf.read_bytes()
    kids = {
        int(n): re.findall(rb"(\d+) 0 R", body)
        for n, body in re.findall(rb"\n(\d+) 0 obj\n<</Type /Pages\n/Count \d+\n/Kids \[([^\]]*)\]", data)
    }
    children = {int(k) for ks in kids.values() for k in ks}
    (root,) = [n for n in kids if n not in children]

    def walk(n: int) -> list[int]:
        return [p for k in kids[n] for p in walk(int(k))] if n in kids else [n]

    order = {obj: i for i, obj in enumerate(walk(root))}
    starts = {name.decode(): order[int(obj)] for name, obj in re.findall(rb"/worker-([^\s\[/]+) \[(\d+) 0 R", data)}
    ends = sorted(starts.values()) + [len(order)]
    per_worker = {w: ends[ends.index(s) + 1] - s for w, s in starts.items()}
    return len(order), per_worker


def test_print_version_pages(rendered_report, tmp_path):
    folder, session, workers, files = rendered_report
    total, per_worker = pdf_pages(folder / PRINT_FILE, tmp_path)
    assert set(per_worker) == {w.worker_id for w in session.workers}
    assert total == 1 + sum(per_worker.values()), "one summary page"
    assert all(1 <= n <= 2 for n in per_worker.values()), per_worker


def test_twenty_workers_print_within_the_limit(crowded_report, tmp_path):
    folder, session, workers, files = crowded_report
    total, per_worker = pdf_pages(folder / PRINT_FILE, tmp_path)
    assert len(per_worker) == 20
    assert total == 1 + sum(per_worker.values()), "one summary page for 20 workers"
    assert all(1 <= n <= 2 for n in per_worker.values()), per_worker


@pytest.mark.parametrize(
    "page, window, print_rules",
    [
        ("index.html", "1280,900", False),
        ("index.html", "800,900", False),
        (worker_page_name("W1"), "800,900", False),
        (worker_page_name("W3"), "800,900", False),
        (PRINT_FILE, f"{A4_PRINTABLE_PX},1000", True),
    ],
    ids=["index", "index-narrow", "worker-rtl", "worker-long", "print"],
)
def test_crowded_pages_keep_their_layout(crowded_report, tmp_path, page, window, print_rules):
    folder, session, workers, files = crowded_report
    found = layout(folder / page, tmp_path, window, print_rules)
    assert found["outside"] == [], found["outside"][:5]
    assert found["overflowing"] == [], found["overflowing"][:5]
    assert found["scroll_width"] <= found["viewport"] + 1
    assert found["names"] >= (20 if page != worker_page_name("W1") else 1)
