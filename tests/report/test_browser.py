"""The quick build's report rendered in headless Chromium, as a reader would open it.

Checks: every image decodes; every link of the table of contents (and every other in-page link)
resolves to an element; every table and figure has an anchor the contents link to; no table is wider
than the text column at a 1 400 px window; no console error; no request leaves the file (no network).
Saves the first screen of each section to ``results/screenshots/`` (``IK_SCREENSHOTS`` to change)
for a person to look at.

Chromium is Debian's ``chromium`` (``workflow/install_system_packages.sh``, run by the README's set-up
command and by CI). Without it the test skips, except under CI (``CI=true``), where it fails.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.report.browser import Browser, find_chromium
from tests.conftest import ROOT

pytestmark = pytest.mark.workflow

WIDTH, HEIGHT = 1400, 900


def _chromium() -> str:
    exe = find_chromium()
    if exe is None:
        reason = "Chromium not installed (bash workflow/install_system_packages.sh installs Debian's chromium)"
        if os.environ.get("CI", "").lower() in ("1", "true", "yes"):
            pytest.fail(reason + ": the browser test must run in CI")
        pytest.skip(reason)
    return exe


@pytest.fixture(scope="module")
def report(request) -> Path:
    """The report of the session's quick build (``IK_REPORT=path/report.html`` to check another one)."""
    if os.environ.get("IK_REPORT"):
        return Path(os.environ["IK_REPORT"]).resolve()
    return request.getfixturevalue("quick_build") / "report.html"


@pytest.fixture(scope="module")
def page(report):
    exe = _chromium()
    browser = Browser(exe, WIDTH, HEIGHT)
    try:
        browser.open(report.as_uri())
        yield browser
    finally:
        browser.close()


_IMAGES = """Promise.all(Array.from(document.images).map(img =>
    img.decode().then(() => null, () => null).then(() =>
        ({alt: img.alt, w: img.naturalWidth, h: img.naturalHeight, shown: img.getBoundingClientRect().width}))))"""

_LINKS = """(() => {
  const bad = [];
  for (const a of document.querySelectorAll('a[href^="#"]')) {
    const id = decodeURIComponent(a.getAttribute('href').slice(1));
    if (!document.getElementById(id)) bad.push(a.getAttribute('href'));
  }
  const toc = Array.from(document.querySelectorAll('#toc a')).map(a => a.getAttribute('href').slice(1));
  const ids = Array.from(document.querySelectorAll('[id]')).map(e => e.id);
  return {bad, toc, duplicates: ids.filter((x, i) => ids.indexOf(x) !== i),
          figures: Array.from(document.querySelectorAll('main figure')).map(f => f.id),
          tables: Array.from(document.querySelectorAll('main div.table, main section[id^="answer-"] > details'))
                       .map(t => t.id)};
})()"""

_WIDE = """(() => {
  document.querySelectorAll('main details').forEach(d => d.open = true);
  const main = document.querySelector('main').getBoundingClientRect();
  const wide = [];
  for (const t of document.querySelectorAll('main table')) {
    const r = t.getBoundingClientRect();
    if (r.right > main.right + 1) {
      const owner = t.closest('[id]');
      wide.push(`${owner ? owner.id : '?'}: ${Math.round(r.width)} px (text column ${Math.round(main.width)} px)`);
    }
  }
  const page = document.documentElement.scrollWidth > window.innerWidth + 1;
  document.querySelectorAll('main details').forEach(d => d.open = false);
  return {wide, page_scrolls: page, toc_sticky: getComputedStyle(document.getElementById('toc')).position};
})()"""


def test_every_image_decodes(page):
    images = page.evaluate(_IMAGES)
    assert images, "the report shows no image"
    broken = [i["alt"] for i in images if not (i["w"] > 0 and i["h"] > 0)]
    assert not broken, broken


def test_every_contents_link_resolves_and_every_table_and_figure_has_one(page):
    links = page.evaluate(_LINKS)
    assert not links["bad"], links["bad"][:10]
    assert not links["duplicates"], links["duplicates"][:10]
    assert links["figures"] and all(links["figures"]), "a figure without an id"
    assert links["tables"] and all(links["tables"]), "a table without an id"
    toc = set(links["toc"])
    missing = [x for x in links["figures"] + links["tables"] if x not in toc]
    assert not missing, f"not in the table of contents: {missing[:10]}"


def test_no_table_needs_a_horizontal_scroll_at_1400_px(page):
    res = page.evaluate(_WIDE)
    assert res["toc_sticky"] == "sticky"
    assert not res["wide"], res["wide"]
    assert not res["page_scrolls"]


def test_no_console_error_and_no_network(page):
    page.drain()
    assert not page.errors(), page.errors()[:10]
    outside = [u for u in page.requests() if not u.startswith(("file:", "data:", "about:"))]
    assert not outside, outside[:10]


def test_screenshots_of_each_section(page):
    """The first screen of every section and the first figure of the answer and of the first study, for a
    person to look at (results/screenshots/)."""
    out = Path(os.environ.get("IK_SCREENSHOTS", ROOT / "results" / "screenshots"))
    sections = page.evaluate("Array.from(document.querySelectorAll('main > section[id]')).map(s => s.id)")
    assert sections and "provenance" in sections
    for old in out.glob("*.png") if out.is_dir() else []:
        old.unlink()
    for k, sid in enumerate(["top", *sections]):
        target = "window.scrollTo(0, 0)" if sid == "top" else f"document.getElementById({sid!r}).scrollIntoView()"
        page.evaluate(f"{target}; new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        page.screenshot(out / f"{k:02d}_{sid}.png")
    # the first figure of the answer and of the first study, at the top of the screen (legibility)
    shown = 0
    first = page.evaluate("(Array.from(document.querySelectorAll('main > section[id]'))"
                          ".find(s => s.id !== 'answer' && s.querySelector('figure')) || {id: ''}).id")
    for sid in (s for s in ("answer", first) if s):
        if page.evaluate(f"(() => {{ const f = document.querySelector('#{sid} figure'); if (!f) return false; "
                         "f.scrollIntoView(); return true; })()"):
            page.evaluate("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
            page.screenshot(out / f"figure_{sid}.png")
            shown += 1
    assert shown >= 1
    # a narrow window: the contents fold into one line above the text
    page.call("Emulation.setDeviceMetricsOverride", {"width": 700, "height": 900, "deviceScaleFactor": 1, "mobile": False})
    try:
        page.open(page.evaluate("location.href.split('#')[0]"))
        state = page.evaluate("({open: document.getElementById('toc-details').open,"
                              " position: getComputedStyle(document.getElementById('toc')).position})")
        page.evaluate("window.scrollTo(0, 0)")
        page.screenshot(out / "narrow_700px.png")
    finally:
        page.call("Emulation.setDeviceMetricsOverride",
                  {"width": WIDTH, "height": HEIGHT, "deviceScaleFactor": 1, "mobile": False})
    assert state == {"open": False, "position": "static"}
    assert len(list(out.glob("*.png"))) == len(sections) + 2 + shown
