"""The report in a real headless browser (Chromium from Debian's packages, kept offline).

- The shipped pages load from file:// with no console message at all (they hold no script, and
  their Content-Security-Policy forbids every load, so any attempt would be logged).
- A TEST-ONLY copy of a page gets one inline script (and a CSP allowing just that) that measures
  the layout and writes the result into the DOM, which --dump-dom returns: every <svg> has a
  non-zero size and fits the window (nothing cut), the headline shares are visible and equal the
  numbers computed here from the per-frame tables, and the page loaded no resource.
- Screenshots of the index and a worker page; ERGOPOSE_DOC_IMAGES=1 copies them to docs/img/.

.ci/run installs Chromium; without it the tests fail under CI and are skipped elsewhere.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from ergopose.report.pages import worker_page_name

pytestmark = pytest.mark.browser

FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-default-apps",
    "--disable-extensions",
    "--hide-scrollbars",
    "--mute-audio",
]
DOCS_IMG = Path(__file__).resolve().parents[2] / "docs" / "img"

PROBE = """<script>
(function () {
  var out = {svgs: [], shares: {}, resources: performance.getEntriesByType('resource').length,
             viewport: document.documentElement.clientWidth, errors: []};
  document.querySelectorAll('svg').forEach(function (s) {
    var r = s.getBoundingClientRect();
    var f = s.closest('figure');
    out.svgs.push({figure: f ? f.id : '', width: r.width, height: r.height, left: r.left, right: r.right});
  });
  document.querySelectorAll('[data-share]').forEach(function (e) {
    var r = e.getBoundingClientRect(), cs = getComputedStyle(e);
    out.shares[e.getAttribute('data-share')] = {text: e.textContent, width: r.width, height: r.height,
      shown: cs.visibility !== 'hidden' && cs.display !== 'none' && cs.color !== cs.backgroundColor};
  });
  var pre = document.createElement('pre');
  pre.id = 'ergopose-probe';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
})();
</script>"""


def chromium() -> str:
    for name in ("chromium", "chromium-browser"):
        exe = shutil.which(name)
        if exe:
            return exe
    if os.environ.get("CI"):
        pytest.fail("Chromium is missing: .ci/run should have installed it (apt-get install chromium)")
    pytest.skip("Chromium is not installed (apt-get install chromium)")


def run_chromium(url: str, tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    profile = Path(os.path.join(tmp_path, f"profile-{len(list(tmp_path.glob('profile-*')))}"))
    profile.mkdir()
    cmd = [chromium(), *FLAGS, f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0", *args, url]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=180, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc


def console_messages(stderr: str) -> list[str]:
    """Console messages Chromium logs with --enable-logging=stderr (any level)."""
    return [line for line in stderr.splitlines() if ":CONSOLE" in line or "Uncaught" in line]


def probe(page: Path, tmp_path: Path, window: str = "1280,800") -> dict:
    html = page.read_text(encoding="utf-8")
    assert "<script" not in html, "the shipped page must hold no script"
    csp = "default-src 'none'; style-src 'unsafe-inline'; img-src data:"
    assert csp in html
    test_copy = page.with_name(f"test-probe-{page.name}")
    test_copy.write_text(
        html.replace(csp, csp + "; script-src 'unsafe-inline'").replace("</body>", PROBE + "</body>"), encoding="utf-8"
    )
    try:
        proc = run_chromium(test_copy.as_uri(), tmp_path, "--dump-dom", f"--window-size={window}")
    finally:
        test_copy.unlink()
    assert console_messages(proc.stderr) == []
    m = re.search(r'<pre id="ergopose-probe">(.*?)</pre>', proc.stdout, flags=re.S)
    assert m, "the probe did not run"
    return json.loads(m.group(1).replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", '"'))


@pytest.mark.parametrize("window", ["1280,800", "800,1000"], ids=["laptop", "narrow"])
def test_worker_page_in_chromium(rendered_report, tmp_path, window):
    folder, session, workers, files = rendered_report
    info, (_, _, frames) = session.workers[1], workers[1]
    result = probe(folder / worker_page_name(info.worker_id), tmp_path, window)
    assert result["resources"] == 0
    figures = [s for s in result["svgs"] if s["figure"]]
    assert len(figures) == len(result["svgs"]) >= 15
    for s in result["svgs"]:
        assert s["width"] > 50 and s["height"] > 30, s
        assert s["left"] >= 0 and s["right"] <= result["viewport"] + 0.5, f"figure cut: {s}"
    for method, col, levels in (("rula", "rula_action_level", range(1, 5)), ("reba", "reba_risk_level", range(0, 5))):
        lv = frames[col].to_numpy(dtype=np.float64, na_value=np.nan)
        for k in levels:
            cell = result["shares"][f"{method}-{k}"]
            assert cell["text"] == f"{100.0 * np.sum(lv == k) / len(lv):.1f} %"
            assert cell["shown"] and cell["width"] > 0 and cell["height"] > 0


def test_index_page_in_chromium(rendered_report, tmp_path):
    folder, session, workers, files = rendered_report
    result = probe(folder / "index.html", tmp_path)
    assert result["resources"] == 0
    assert len(result["svgs"]) == 3  # the shift by time of day and one overview per method
    for s in result["svgs"]:
        assert s["width"] > 50 and s["height"] > 30 and s["right"] <= result["viewport"] + 0.5


def test_shipped_pages_load_silently_and_screenshots(rendered_report, tmp_path):
    folder, session, workers, files = rendered_report
    shots = {}
    for page, name, window in (
        (folder / "index.html", "report-index.png", "1280,1500"),
        (folder / worker_page_name("W2"), "report-worker.png", "1280,2300"),
    ):
        png = tmp_path / name
        proc = run_chromium(page.as_uri(), tmp_path, f"--screenshot={png}", f"--window-size={window}")
        assert console_messages(proc.stderr) == []
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        import cv2

        img = cv2.imread(str(png))
        w, h = (int(v) for v in window.split(","))
        assert img.shape[:2] == (h, w)
        assert img.std() > 20, "the screenshot is blank"
        shots[name] = png
    if os.environ.get("ERGOPOSE_DOC_IMAGES") == "1":
        DOCS_IMG.mkdir(parents=True, exist_ok=True)
        for name, png in shots.items():
            shutil.copyfile(png, DOCS_IMG / name)


def test_prints_to_a4_pdf(rendered_report, tmp_path):
    folder, session, workers, files = rendered_report
    pdf = tmp_path / "worker.pdf"
    proc = run_chromium(
        (folder / worker_page_name("W1")).as_uri(), tmp_path, f"--print-to-pdf={pdf}", "--no-pdf-header-footer"
    )
    assert console_messages(proc.stderr) == []
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF")
    # A4 media box: 595 x 842 points (Chromium writes it on every page)
    boxes = re.findall(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", data)
    assert boxes and all(abs(float(w) - 595.92) < 1.5 and abs(float(h) - 842.88) < 1.5 for w, h in boxes)
    # page breaks before the major sections: at least one page per section (10) plus the summary
    assert len(boxes) >= 11
