"""The lecturers' HTML pages work offline: rendered with the offline template
(:mod:`vehicle_observers.results.html`), opened from disk in headless Chromium with every
network request blocked, and the equations counted once MathJax has typeset them.

The pages are rendered from the notebooks as stored (markdown with the model's equations; no
outputs needed), so the test runs without ``make figures``; ``make html`` renders the executed
copies with the same exporter. A page that loads MathJax from a CDN would typeset nothing here:
the planted CDN page below must fail the same count.
"""

from __future__ import annotations

import re

import nbformat
import pytest
from labkit import ROOT, chromium_path, require_browser, start_chromium, stop
from vehicle_observers.results import html

require_browser("offline HTML test")

pytestmark = [pytest.mark.xdist_group("offline_html")]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def math_count(nb_path) -> int:
    """Display (``$$..$$``) plus inline (``$..$``) formulas in the markdown cells."""
    nb = nbformat.read(str(nb_path), as_version=4)
    md = "\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    disp = re.findall(r"\$\$(.+?)\$\$", md, re.S)
    rest = re.sub(r"\$\$(.+?)\$\$", "", md, flags=re.S)
    inline = re.findall(r"(?<![\\$])\$(?!\$)(.+?)(?<![\\$])\$", rest, re.S)
    return len(disp) + len(inline)


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    out = tmp_path_factory.mktemp("html")
    return html.write_html(NOTEBOOKS, out)


@pytest.fixture(scope="module")
def offline_page(tmp_path_factory):
    """A Playwright page on the system Chromium in which every non-file request is aborted
    (and recorded)."""
    from playwright.sync_api import sync_playwright

    proc, cdp = start_chromium(chromium_path(), tmp_path_factory.mktemp("chromium"))
    try:
        with sync_playwright() as p:
            b = p.chromium.connect_over_cdp(cdp)
            ctx = b.contexts[0]
            blocked = []

            def guard(route):
                if route.request.url.startswith(("file:", "data:")):
                    return route.continue_()
                blocked.append(route.request.url)
                return route.abort()

            ctx.route("**/*", guard)
            page = ctx.new_page()
            yield page, blocked
            b.close()
    finally:
        stop(proc)


def typeset(page, path) -> tuple[int, int]:
    """(typeset formulas, formulas MathJax reported as errors) once MathJax is done; (0, 0)
    when MathJax never loaded (the page's load event has fired: a blocked script failed)."""
    page.goto(path.as_uri(), wait_until="load")
    if not page.evaluate("() => !!(window.MathJax && window.MathJax.startup)"):
        return 0, 0
    page.evaluate("() => MathJax.startup.promise")
    return (page.locator("mjx-container").count(),
            page.locator("mjx-container [data-mjx-error], mjx-merror").count())


def test_no_page_fetches_an_external_url(pages):
    for p in pages:
        assert html.external_urls(p.read_text()) == [], p.name
    assert (pages[0].parent / html.MATHJAX_REL).is_file()


@pytest.mark.parametrize("i", range(len(NOTEBOOKS)), ids=[p.stem for p in NOTEBOOKS])
def test_equations_typeset_with_the_network_blocked(pages, offline_page, i):
    page, blocked = offline_page
    expected = math_count(NOTEBOOKS[i])
    assert expected > 20, "a notebook with the model's equations"
    n, errors = typeset(page, pages[i])
    assert blocked == [], f"requests to the network: {blocked[:3]}"
    assert n >= expected and errors == 0, (pages[i].name, n, expected, errors)
    shots = ROOT / "build" / "screenshots"
    shots.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(shots / f"offline_{pages[i].stem}.png"))


def test_a_page_loading_mathjax_from_a_cdn_typesets_nothing_offline(pages, offline_page, tmp_path):
    page, blocked = offline_page
    body = pages[0].read_text().replace(html.MATHJAX_REL,
                                        "https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-svg.js")
    planted = tmp_path / "cdn.html"
    planted.write_text(body)
    assert html.external_urls(body) == ["https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-svg.js"]
    n, _ = typeset(page, planted)
    assert n == 0 and any("jsdelivr" in u for u in blocked)
    blocked.clear()
