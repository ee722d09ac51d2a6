"""Executed notebooks as standalone HTML pages that need no network (``make html``).

nbconvert's ``lab`` look, figures embedded as images, and MathJax 3 from a copy in the
repository's environment (the PyPI package ``django-static-mathjax``, which installs MathJax's
release files as the module ``mathjax``; only its self-contained ``es5/tex-svg.js`` is used,
copied to ``<out>/_static/mathjax/``). The template (``templates/offline``) drops require.js
and the widget and mermaid loaders, which the lab template fetches from a CDN and these
notebooks do not use. :func:`external_urls` lists any URL a page would still fetch; the
export refuses to write a page that has one.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

TEMPLATES = Path(__file__).parent / "templates"
#: where the MathJax script goes, relative to the HTML pages
MATHJAX_REL = "_static/mathjax/tex-svg.js"

_FETCH = re.compile(r"""<(?:script|link|img|iframe)\b[^>]*?\b(?:src|href)\s*=\s*["']([^"']+)["']""",
                    re.I)
_CSS_URL = re.compile(r"""(?:@import\s+|url\()\s*["']?((?:https?:)?//[^"')\s]+)""", re.I)
_IMPORT = re.compile(r"""import\(\s*["']((?:https?:)?//[^"']+)["']""")


def mathjax_source() -> Path:
    """MathJax's self-contained SVG build in the environment (``tex-svg.js``)."""
    try:
        import mathjax
    except ImportError as e:   # the environment lacks the pinned package
        raise FileNotFoundError("MathJax is not installed: pip install django-static-mathjax "
                                "(pinned in environment.txt)") from e
    src = Path(mathjax.__file__).parent / "static" / "mathjax" / "es5" / "tex-svg.js"
    if not src.is_file():
        raise FileNotFoundError(f"{src} missing from the MathJax package")
    return src


def external_urls(html: str) -> list[str]:
    """URLs the page would fetch from the network: ``src``/``href`` of scripts, links, images
    and frames, CSS ``url()``/``@import`` and JavaScript ``import()`` that are absolute
    (``http(s)://`` or protocol-relative). Plain ``<a href>`` links are not fetched and not
    listed; ``data:`` URIs and relative paths are local."""
    out = [u for u in _FETCH.findall(html) if re.match(r"(?:https?:)?//", u)]
    out += _CSS_URL.findall(html) + _IMPORT.findall(html)
    return sorted(set(out))


def exporter():
    """An nbconvert HTMLExporter with the offline template and the local MathJax URL."""
    from nbconvert import HTMLExporter

    return HTMLExporter(template_name="offline", extra_template_basedirs=[str(TEMPLATES)],
                        embed_images=True, mathjax_url=MATHJAX_REL)


WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"


def static_widgets(nb):
    """``nb`` with every widget output that also carries an ``image/png`` (a live figure's
    initial state, :func:`vehicle_observers.results.teaching.live_figure`) reduced to that
    image: a page has no widget manager and no saved widget state, so the widget would render
    as nothing. Returns the number of outputs changed."""
    n = 0
    for cell in nb.cells:
        for out in cell.get("outputs", []):
            data = out.get("data", {})
            if WIDGET_VIEW in data and "image/png" in data:
                del data[WIDGET_VIEW]
                n += 1
    return n


def write_html(executed: list[Path], out_dir: Path) -> list[Path]:
    """Render executed notebooks to ``out_dir/<notebook>.html`` (input cells kept, image
    outputs embedded, live figures as their initial image: :func:`static_widgets`) and copy
    MathJax beside them. Raises ``FileNotFoundError`` naming a
    missing executed copy, ``ValueError`` naming a page that would fetch an external URL."""
    import nbformat

    exp = exporter()
    out_dir.mkdir(parents=True, exist_ok=True)
    mj = out_dir / MATHJAX_REL
    mj.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(mathjax_source(), mj)
    written = []
    for nb in executed:
        if not nb.exists():
            raise FileNotFoundError(f"executed notebook {nb} not found (run the pipeline first)")
        node = nbformat.read(str(nb), as_version=4)
        static_widgets(node)
        body, _ = exp.from_notebook_node(node, resources={"metadata": {"name": nb.stem}})
        ext = external_urls(body)
        if ext:
            raise ValueError(f"{nb.name}: the HTML page would fetch {len(ext)} external "
                             f"URL(s), e.g. {ext[0]}")
        path = out_dir / f"{nb.stem}.html"
        path.write_text(body, encoding="utf-8")
        written.append(path)
    return written
