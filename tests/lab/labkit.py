"""JupyterLab started the way users start it (``make lab``), and the project's notebooks run in it.

- :func:`start_lab` runs ``make lab LAB_ARGS=...`` (headless, a free local port, a token, a
  temporary notebook folder) in its own process group and waits for ``/api/status``;
  :func:`stop` ends it by its process id (the group ``make`` leads).
- :func:`parameterised_copies` writes each notebook with papermill's injected ``parameters``
  (``quick=True``, ``figures_dir`` in the temporary folder) without executing it.
- :func:`run_in_kernel` executes a notebook's code cells through the server's REST API and the
  kernel websocket (what the Lab front end does), collecting the outputs as nbformat dicts.
- :func:`lab_problems` turns what a run produced into one line per problem (empty when fine).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from urllib.request import Request, urlopen

from vehicle_observers.data.logs import repo_root
from vehicle_observers.results import pipeline

ROOT = repo_root()
KERNEL = "vehicle-observers"
#: settings for the Lab the tests open: every cell kept in the page (no windowing, so image
#: outputs can be counted), no news or update check
LAB_SETTINGS = {
    "@jupyterlab/notebook-extension/tracker.jupyterlab-settings": {"windowingMode": "none"},
    "@jupyterlab/apputils-extension/notification.jupyterlab-settings":
        {"fetchNews": "false", "checkForUpdates": False},
}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop(proc: subprocess.Popen, timeout: float = 30.0) -> None:
    """SIGTERM to the process group led by ``proc.pid``, SIGKILL if still alive after ``timeout``."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(10)
    except ProcessLookupError:
        pass


@dataclass
class Lab:
    url: str
    token: str
    root_dir: Path
    proc: subprocess.Popen
    log: Path
    command: list = field(default_factory=list)

    def api(self, path: str, method: str = "GET", body: dict | None = None, timeout: float = 30):
        """JSON answer of the server's REST API (``path`` below ``/api/``)."""
        data = None if body is None else json.dumps(body).encode()
        req = Request(f"{self.url}/api/{path}", data=data, method=method,
                      headers={"Authorization": f"token {self.token}",
                               "Content-Type": "application/json"})
        with urlopen(req, timeout=timeout) as r:
            raw = r.read()
        return json.loads(raw) if raw else None


def lab_env(settings_dir: Path) -> dict:
    """The environment ``make lab`` gets from a user's shell: none of the test run's matplotlib
    backend or make variables; Lab settings and workspaces in ``settings_dir``."""
    env = {k: v for k, v in os.environ.items()
           if k not in {"MPLBACKEND", "MAKEFLAGS", "MFLAGS", "MAKELEVEL", "PYTEST_XDIST_WORKER",
                        "PYTEST_CURRENT_TEST"}}
    for rel, value in LAB_SETTINGS.items():
        p = settings_dir / "settings" / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(json.dumps(value))
    env["JUPYTERLAB_SETTINGS_DIR"] = str(settings_dir / "settings")
    env["JUPYTERLAB_WORKSPACES_DIR"] = str(settings_dir / "workspaces")
    env["JUPYTER_RUNTIME_DIR"] = str(settings_dir / "runtime")
    return env


def start_lab(root_dir: Path, work: Path, timeout: float = 180.0) -> Lab:
    """``make lab`` on a free port serving ``root_dir``; returns when ``/api/status`` answers.
    Raises ``RuntimeError`` with the server's log if it exits or does not answer in time."""
    port, token = free_port(), uuid.uuid4().hex
    args = (f"--no-browser --ip=127.0.0.1 --port={port} --IdentityProvider.token={token} "
            "--LabApp.expose_app_in_browser=True "
            "--ServerApp.port_retries=0")
    # -o: use the environment as it is (never reinstall it from a test)
    cmd = ["make", "--no-print-directory", "-o", ".venv/.installed", "lab", f"LAB_ARGS={args}",
           f"LAB_DIR={root_dir}"]
    log = work / "lab-server.log"
    with open(log, "wb") as fh:
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, env=lab_env(work),
                                start_new_session=True)
    lab = Lab(f"http://127.0.0.1:{port}", token, root_dir, proc, log, cmd)
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise RuntimeError(f"`make lab` exited with {proc.returncode}:\n{log.read_text()[-3000:]}")
        try:
            lab.api("status", timeout=5)
            return lab
        except OSError:
            time.sleep(0.5)
    stop(proc)
    raise RuntimeError(f"JupyterLab did not answer within {timeout:.0f} s:\n{log.read_text()[-3000:]}")


def parameterised_copies(names: list[str], dest: Path, figures_dir: Path, seed: int = 0) -> list[Path]:
    """``dest/<name>.ipynb``: the notebook with papermill's injected parameters (quick mode,
    ``figures_dir``), not executed."""
    import nbformat
    from papermill.iorw import load_notebook_node
    from papermill.parameterize import parameterize_notebook

    dest.mkdir(parents=True, exist_ok=True)
    out = []
    for name in names:
        nb = load_notebook_node(str(pipeline.notebook_path(name, ROOT)))
        nb = parameterize_notebook(nb, {"seed": seed, "quick": True,
                                        "figures_dir": str(figures_dir)})
        nbformat.write(nb, str(dest / f"{name}.ipynb"))
        out.append(dest / f"{name}.ipynb")
    return out


def _msg(code: str, session: str) -> dict:
    return {"header": {"msg_id": uuid.uuid4().hex, "msg_type": "execute_request",
                       "username": "test", "session": session, "version": "5.3"},
            "parent_header": {}, "metadata": {}, "channel": "shell", "buffers": [],
            "content": {"code": code, "silent": False, "store_history": True,
                        "user_expressions": {}, "allow_stdin": False, "stop_on_error": True}}


def _output(msg: dict) -> dict | None:
    """The nbformat output of an iopub message (None for status and other messages)."""
    t, c = msg["msg_type"], msg["content"]
    if t == "stream":
        return {"output_type": "stream", "name": c["name"], "text": c["text"]}
    if t in ("display_data", "execute_result"):
        return {"output_type": t, "data": c["data"]}
    if t == "error":
        return {"output_type": "error", "ename": c["ename"], "evalue": c["evalue"],
                "traceback": c["traceback"]}
    return None


def run_in_kernel(lab: Lab, kernel_id: str, sources: list[str], timeout: float = 600.0) -> list[list]:
    """Execute ``sources`` one after the other in a running kernel through its websocket
    (``/api/kernels/<id>/channels``); returns each cell's outputs, stopping after an error."""
    import websocket

    ws_url = lab.url.replace("http", "ws", 1) + f"/api/kernels/{kernel_id}/channels"
    ws = websocket.create_connection(ws_url, header=[f"Authorization: token {lab.token}"],
                                     timeout=timeout)
    session, results = uuid.uuid4().hex, []
    try:
        for src in sources:
            msg = _msg(src, session)
            ws.send(json.dumps(msg))
            outs, done, t0 = [], False, time.monotonic()
            while not done:
                if time.monotonic() - t0 > timeout:
                    raise TimeoutError(f"cell did not finish in {timeout:.0f} s: {src[:60]!r}")
                reply = json.loads(ws.recv())
                if reply.get("parent_header", {}).get("msg_id") != msg["header"]["msg_id"]:
                    continue
                if reply["channel"] == "iopub":
                    out = _output(reply)
                    if out is not None:
                        outs.append(out)
                    done = (reply["msg_type"] == "status"
                            and reply["content"]["execution_state"] == "idle")
            results.append(outs)
            if any(o["output_type"] == "error" for o in outs):
                break
    finally:
        ws.close()
    return results


def saved_figures(figures_dir: Path, name: str) -> list[str] | None:
    """PNG figures the run of ``name`` listed in its metrics.json, or for a lesson (which
    records no metrics) the PNG files of its ``lesson/`` folder (``teaching.Lesson``); None if
    it wrote neither."""
    mj = figures_dir / name / "metrics.json"
    lesson = figures_dir / name / "lesson"
    if not mj.exists() and lesson.is_dir():
        return sorted(p.stem for p in lesson.glob("*.png")) or None
    if not mj.exists():
        return None
    return sorted(f[:-4] for f in json.loads(mj.read_text())["files"] if f.endswith(".png"))


def lab_problems(name: str, errors: list[str], n_images: int, figures: list[str] | None,
                 widget_errors: list[str] = ()) -> list[str]:
    """One line per problem of a notebook run in Lab: error outputs, fewer rendered images
    than saved figures, no metrics.json, widget error placeholders."""
    problems = [f"{name}: error output: {e}" for e in errors]
    if figures is None:
        problems.append(f"{name}: wrote no metrics.json (the run did not reach rep.write())")
    elif n_images < len(figures):
        problems.append(f"{name}: {n_images} rendered images for {len(figures)} saved figures "
                        f"({', '.join(figures)})")
    problems += [f"{name}: widget error placeholder: {w}" for w in widget_errors]
    return problems


#: notebooks whose lesson has a live figure (a slider redrawing it): the browser test moves it
SLIDER_NOTEBOOKS = ("03_interval_observer", "04_bicycle_dmvt", "05_sliding_mode_observers")


def teaching_problems(name: str, cells: list[dict], slider: dict | None = None) -> list[str]:
    """A teaching notebook has one cell tagged ``knobs``, at least one ``**Try this.**`` prompt
    and one ``animation`` cell; a notebook of :data:`SLIDER_NOTEBOOKS` has a live figure whose
    image changes when its slider moves (``slider``: :func:`drive_slider`'s answer).
    ``cells``: dicts with ``cell_type``, ``source`` and ``tags``. (The exercises are checked
    by ``exercise_problems`` of ``tests/test_executed_notebooks.py``.)"""
    knobs = sum("knobs" in c["tags"] for c in cells)
    md = [c["source"].lstrip() for c in cells if c["cell_type"] == "markdown"]
    problems = []
    if knobs != 1:
        problems.append(f"{name}: {knobs} cells tagged 'knobs' (want exactly 1)")
    if not any("**Try this.**" in s for s in md):
        problems.append(f"{name}: no '**Try this.**' prompt under a figure")
    if not any("animation" in c["tags"] for c in cells) and not name.startswith("00"):
        problems.append(f"{name}: no cell tagged 'animation' (an HTML5 animation of the observer)")
    if name in SLIDER_NOTEBOOKS or slider is not None:
        if slider is None:
            problems.append(f"{name}: no live figure (slider above a redrawn image) in the page")
        elif not slider["changed"]:
            problems.append(f"{name}: moving the slider to {slider['value']} did not change the "
                            f"figure")
    return problems


# ---------------------------------------------------------------- the browser -----------------

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage", "--window-size=1400,1000"]


def chromium_path() -> str | None:
    """The system Chromium (Debian package ``chromium``), or None; ``VO_CHROMIUM`` names
    another binary (and only that one is tried)."""
    import shutil

    chosen = os.environ.get("VO_CHROMIUM")
    candidates = [chosen] if chosen else [CHROMIUM, shutil.which("chromium"),
                                          shutil.which("chromium-browser")]
    for p in candidates:
        if p and os.access(p, os.X_OK):
            return p
    return None


def require_browser(what: str) -> None:
    """Skip the calling test module (one line saying how to enable it) without the system
    Chromium or Playwright; ``VO_REQUIRE_BROWSER=1`` (set by ``.ci/run``) turns the skip into
    a failure. Call at module level."""
    import pytest

    how = (f"{what} skipped: no system Chromium (install it: apt-get install -y chromium; "
           "or set VO_CHROMIUM=/path/to/chromium)")
    if chromium_path() is None:
        if os.environ.get("VO_REQUIRE_BROWSER"):
            raise RuntimeError(how.replace("skipped", "required (VO_REQUIRE_BROWSER=1)"))
        pytest.skip(how, allow_module_level=True)
    pytest.importorskip("playwright", reason=f"{what} skipped: playwright is not installed "
                        "(make env installs it from environment.txt)")


def start_chromium(exe: str, work: Path, timeout: float = 60.0):
    """Headless Chromium with a new empty profile in ``work/profile`` and a DevTools port it picks
    itself; returns ``(process, cdp_url)``. Ended with :func:`stop`."""
    profile = work / "profile"
    profile.mkdir(parents=True, exist_ok=True)
    log = work / "chromium.log"
    with open(log, "wb") as fh:
        proc = subprocess.Popen([exe, *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
                                 "--remote-debugging-address=127.0.0.1", "--remote-debugging-port=0",
                                 "about:blank"], stdout=fh, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
    port_file, t0 = profile / "DevToolsActivePort", time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise RuntimeError(f"chromium exited with {proc.returncode}:\n{log.read_text()[-3000:]}")
        if port_file.exists() and port_file.read_text().strip():
            return proc, f"http://127.0.0.1:{port_file.read_text().split()[0]}"
        time.sleep(0.2)
    stop(proc)
    raise RuntimeError(f"chromium gave no DevTools port within {timeout:.0f} s:\n{log.read_text()[-3000:]}")


_LAB_READY = """() => { const w = window.jupyterapp && window.jupyterapp.shell.currentWidget;
  const k = w && w.sessionContext && w.sessionContext.session && w.sessionContext.session.kernel;
  return !!(k && k.status === 'idle' && w.content && w.content.widgets.length); }"""

_LAB_DONE = """() => { const w = window.jupyterapp.shell.currentWidget;
  const k = w.sessionContext.session && w.sessionContext.session.kernel;
  if (!k || k.status !== 'idle') return false;
  const code = w.content.widgets.filter(c => c.model.type === 'code'
                                        && c.model.sharedModel.getSource().trim());
  const failed = code.some(c => c.model.outputs.toJSON().some(o => o.output_type === 'error'));
  const pending = code.some(c => c.promptNode && c.promptNode.textContent.includes('*'));
  return !pending && (failed || code.every(c => c.model.executionCount !== null)); }"""

_LAB_STATE = """() => { const w = window.jupyterapp.shell.currentWidget;
  const imgs = [...w.node.querySelectorAll('.jp-OutputArea-output img')];
  const outs = [...w.node.querySelectorAll('.jp-OutputArea-output')].map(e => e.innerText);
  return {kernel: w.sessionContext.session.kernel.name, session: w.sessionContext.session.id,
    images: imgs.filter(i => i.complete && i.naturalWidth > 0).length,
    widget_errors: outs.filter(t => /Error displaying widget|model not found/i.test(t))
                       .map(t => t.slice(0, 160)),
    cells: w.content.widgets.map(c => ({cell_type: c.model.type,
      source: c.model.sharedModel.getSource(), tags: c.model.getMetadata('tags') || [],
      hidden: !!((c.model.getMetadata('jupyter') || {}).source_hidden),
      rendered: c.model.type !== 'markdown' || c.rendered,
      outputs: c.model.type === 'code' ? c.model.outputs.toJSON() : []}))}; }"""


#: the image of the first live figure (an ipywidgets slider above an Output widget) in the page
_LIVE_IMAGE = """() => { const s = document.querySelector('.jp-OutputArea-output .widget-slider');
  if (!s) return null;
  const box = s.closest('.widget-vbox');
  const img = box && box.querySelector('.widget-output img');
  return img ? img.src : ''; }"""


def drive_slider(page, timeout_ms: int = 30_000) -> dict | None:
    """Move the first slider of the page one step (keyboard, as a user would) and wait for the
    image of its live figure to change. ``None`` when the page has no slider, else
    ``{"changed": bool, "value": readout after the move, "before"/"after": image lengths}``."""
    before = page.evaluate(_LIVE_IMAGE)
    if before is None:
        return None
    handle = page.locator(".jp-OutputArea-output .widget-slider .noUi-handle").first
    handle.scroll_into_view_if_needed()
    handle.focus()
    page.keyboard.press("ArrowRight")
    changed = True
    try:
        page.wait_for_function(f"() => {{ const s = ({_LIVE_IMAGE})(); "
                               f"return s && s !== {json.dumps(before)}; }}", polling=500,
                               timeout=timeout_ms)
    except Exception:  # playwright's TimeoutError: the figure did not change
        changed = False
    after = page.evaluate(_LIVE_IMAGE) or ""
    value = page.locator(".jp-OutputArea-output .widget-slider .widget-readout").first.inner_text()
    return {"changed": changed and bool(before), "value": value, "before": len(before),
            "after": len(after)}


def cells_notebook(cells: list[dict]):
    """The cells read from the page as an nbformat notebook (tags, hidden source, outputs), for
    the output and exercise checkers of ``tests/test_executed_notebooks.py``."""
    import nbformat
    from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

    nb = new_notebook()
    for c in cells:
        meta = {"tags": list(c["tags"])}
        if c.get("hidden"):
            meta["jupyter"] = {"source_hidden": True}
        if c["cell_type"] == "code":
            cell = new_code_cell(c["source"], metadata=meta)
            cell.outputs = [nbformat.from_dict(o) for o in c["outputs"]]
        else:
            cell = new_markdown_cell(c["source"], metadata=meta)
        nb.cells.append(cell)
    return nb


@dataclass
class LabRun:
    """What a notebook run through the Lab UI left in the page."""
    name: str
    kernel: str
    images: int
    cells: list
    widget_errors: list
    figures: list | None
    screenshot: Path
    seconds: float
    #: what moving the first slider did (:func:`drive_slider`), None without a slider
    slider: dict | None = None

    @property
    def errors(self) -> list[str]:
        return [f"cell {i}: {o['ename']}: {o['evalue']}" for i, c in enumerate(self.cells)
                for o in c["outputs"] if o.get("output_type") == "error"]

    def problems(self) -> list[str]:
        return lab_problems(self.name, self.errors, self.images, self.figures, self.widget_errors)


def run_in_lab(context, lab: Lab, name: str, figures_dir: Path, shots: Path,
               timeout: float = 900.0) -> LabRun:
    """Open ``<lab root>/<name>.ipynb`` in a new page, Run All Cells from the Run menu, wait for
    the kernel to finish (every non-empty code cell executed, or an error), read cells, outputs
    and rendered images from the page, save a screenshot ``shots/<name>.png``, shut the kernel
    down."""
    import re
    import shutil

    shutil.rmtree(figures_dir / name, ignore_errors=True)  # no figures left from an earlier run
    t0 = time.monotonic()
    page = context.new_page()
    page.set_default_timeout(120_000)
    try:
        page.goto(f"{lab.url}/lab/tree/{name}.ipynb?reset&token={lab.token}")
        page.wait_for_function(_LAB_READY, polling=500, timeout=180_000)
        page.locator("#jp-MainMenu .lm-MenuBar-itemLabel", has_text=re.compile(r"^Run$")).click()
        page.locator(".lm-Menu .lm-Menu-itemLabel", has_text=re.compile(r"^Run All Cells$")).click()
        page.wait_for_timeout(1000)
        page.wait_for_function(_LAB_DONE, polling=1000, timeout=timeout * 1000)
        page.wait_for_timeout(500)  # let the last images decode
        state = page.evaluate(_LAB_STATE)
        shots.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(shots / f"{name}.png"))
        slider = drive_slider(page)
        if slider is not None:
            page.screenshot(path=str(shots / f"{name}-slider.png"))
        lab.api(f"sessions/{state['session']}", "DELETE")
    finally:
        page.close()
    return LabRun(name, state["kernel"], state["images"], state["cells"], state["widget_errors"],
                  saved_figures(figures_dir, name), shots / f"{name}.png", time.monotonic() - t0,
                  slider)
