"""Regenerate every figure: run each notebook in ``notebooks/`` with papermill, headless.

    python -m vehicle_observers.results.pipeline [--quick] [--seed 0] [--only 01,03]
                                         [--figures figures] [--build build/notebooks]
                                         [--timeout 1200] [--html build/html]

Notebooks run in name order with parameters ``seed``, ``quick`` and ``figures_dir``; the
executed copies go to ``--build`` (ignored by git) for inspection. On a failing cell the
run stops with the notebook name, the cell number and the error, and keeps the partial
executed copy. After a full run, ``REPRODUCTION.md`` is rebuilt from the claims every
notebook wrote into ``figures/<notebook>/metrics.json`` (paper claims first with their own
tally; benchmark targets, diagnostics, baselines and data checks apart). With ``--html DIR`` the executed
copies of the same run are also rendered to ``DIR/<notebook>.html`` (nbconvert, JupyterLab look,
figures embedded, MathJax copied beside the pages: no network needed) for reading without a
kernel (``make html``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import textwrap
import time
from pathlib import Path

from vehicle_observers.data.logs import repo_root
from vehicle_observers.results.rules import KINDS, VERDICTS, Rule, RuleError, distinguishing_digits, fmt

KERNEL = "vehicle-observers"


#: the three kinds of notebook of a section ``NN_name``, by where they live: the lesson
#: ``notebooks/NN_name.ipynb`` (teaching only), its reproduction report
#: ``notebooks/reports/NN_name_report.ipynb`` (metrics, claims, verdicts, forensics) and the
#: worked solutions of its exercises ``notebooks/solutions/NN_name_solutions.ipynb``
NOTEBOOK_KINDS = {"lesson": ("", "[0-9][0-9]_*.ipynb"),
                  "report": ("reports", "[0-9][0-9]_*_report.ipynb"),
                  "solutions": ("solutions", "[0-9][0-9]_*_solutions.ipynb")}


def notebooks(root: Path | None = None, kinds=("lesson", "report")) -> list[Path]:
    """The notebooks of ``kinds`` (:data:`NOTEBOOK_KINDS`), sorted by file name (a section's
    lesson, then its report and solutions). The pipeline regenerates lessons and reports; the
    tests also run the solutions."""
    root = root or repo_root()
    out = []
    for kind in kinds:
        folder, pattern = NOTEBOOK_KINDS[kind]
        out += (root / "notebooks" / folder).glob(pattern)
    return sorted(out, key=lambda p: p.name)


def notebook_path(name: str, root: Path | None = None) -> Path:
    """The path of the notebook whose stem is ``name`` (a lesson, a report or solutions)."""
    root = root or repo_root()
    for kind in ("report", "solutions"):
        if name.endswith("_" + ("solutions" if kind == "solutions" else "report")):
            return root / "notebooks" / NOTEBOOK_KINDS[kind][0] / f"{name}.ipynb"
    return root / "notebooks" / f"{name}.ipynb"


def section_of(name: str) -> str:
    """The section ``NN_name`` of a notebook stem (``NN_name``, ``NN_name_report`` or
    ``NN_name_solutions``): the folder ``figures/NN_name/`` its figures and metrics go to."""
    for suffix in ("_report", "_solutions"):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return name


def notebook_kind(nb: Path) -> str:
    """``"lesson"``, ``"report"`` or ``"solutions"`` of a notebook path."""
    folder = nb.parent.name
    return {"reports": "report", "solutions": "solutions"}.get(folder, "lesson")


def kernel_name() -> str:
    """The project's kernel if registered (``make`` does it), else the interpreter's own."""
    from jupyter_client.kernelspec import KernelSpecManager

    specs = KernelSpecManager().find_kernel_specs()
    return KERNEL if KERNEL in specs else "python3"


def run_notebook(nb: Path, out: Path, figures_dir: Path, seed: int = 0, quick: bool = False,
                 timeout: int = 1200, kernel: str | None = None):
    """Execute one notebook; raises ``papermill.PapermillExecutionError`` on a failing cell."""
    import papermill as pm

    os.environ.setdefault("MPLBACKEND", "Agg")
    out.parent.mkdir(parents=True, exist_ok=True)
    figures_dir.mkdir(parents=True, exist_ok=True)
    return pm.execute_notebook(
        str(nb), str(out),
        parameters={"seed": int(seed), "quick": bool(quick),
                    "figures_dir": str(figures_dir.resolve())},
        kernel_name=kernel or kernel_name(), cwd=str(nb.parent), execution_timeout=timeout,
        progress_bar=False, log_output=False, request_save_on_cell_execute=False,
        kernel_manager_class=ipc_kernel_manager())


def ipc_kernel_manager():
    """A kernel manager whose kernel talks over local sockets (ZeroMQ ``ipc``, files named after
    the kernel's own connection file) instead of TCP ports. Two notebooks started at once in two
    processes (the pipeline's ``--jobs``, the parallel test workers) each pick "free" TCP ports
    by binding and releasing them; the other process can take the same port before the kernel
    binds it, and the client then waits for a reply that never comes. The socket files carry a
    random prefix in the temporary folder, so they cannot collide (and are removed with the
    kernel)."""
    import tempfile
    import uuid

    from jupyter_client.manager import AsyncKernelManager
    from traitlets import default

    class IPCKernelManager(AsyncKernelManager):
        @default("transport")
        def _transport_default(self):
            return "ipc"

        @default("ip")
        def _ip_default(self):
            # the socket files' prefix: unique per kernel (jupyter_client's default,
            # "kernel-ipc" in the working directory, is shared by kernels started together)
            return os.path.join(tempfile.gettempdir(), f"vo-kernel-{uuid.uuid4().hex[:16]}")

    return IPCKernelManager


def write_html(executed: list[Path], out_dir: Path) -> list[Path]:
    """Render executed notebooks to standalone offline HTML (:func:`results.html.write_html`)."""
    from vehicle_observers.results.html import write_html as offline

    return offline(executed, out_dir)


#: one paragraph under the title of each kind's section of REPRODUCTION.md
KIND_INTROS = {
    "paper": "Claims printed in the papers (or shown by their figures): the reproduction proper. "
             "Only these are counted as reproduced or not.",
    "target": "Targets chosen in this repository for the benchmark of notebook 07 (accuracy on "
              "the real log, margin over the open-loop model, an interval observer for every "
              "car); no paper makes them.",
    "diagnostic": "Checks of a model or a method that explain a result (the smoother against "
                  "the filter, whiteness of the innovations as a test of the model); no paper "
                  "claims them for these data, and a failed diagnostic is a finding about the "
                  "model, not a claim that fails.",
    "baseline": "Numbers of a baseline estimator (EKF, UKF) run beside a paper's observer on the "
                "same data; the papers have no such baseline.",
    "data": "Checks of a data set against the numbers of its provenance file.",
}
TABLE_HEADER = ["| paper | item | figure | metric | value | paper / target | verdict | "
                "threshold from, note |", "|---|---|---|---|---|---|---|---|"]


def _kind(claim: dict) -> str:
    return claim.get("kind", "paper")


def tally(claims: list[dict], zeros: bool = True) -> str:
    """``"a reproduced (b of which hold but prove little), c partly, d differs, e not
    comparable"`` of ``claims`` (metrics.json claim dicts); verdicts with no claim are left
    out unless ``zeros``."""
    parts = []
    for v in VERDICTS:
        sel = [c for c in claims if c["verdict"] == v]
        weak = sum(bool(c.get("proves_little")) for c in sel)
        if sel or zeros:
            parts.append(f"{len(sel)} {v}" + (f" ({weak} of which hold but prove little)"
                                               if weak else ""))
    return ", ".join(parts)


def _count(n: int, kind: str) -> str:
    """``"47 paper claims"``, ``"1 data check"``."""
    title = KINDS[kind]
    return f"{n} {title if n != 1 else title[:-1]}"


def claim_value_text(claim: dict, metrics: dict) -> str:
    """The claim's value with the rule's digits, more when it is close to one of the rule's
    thresholds (:func:`rules.distinguishing_digits`: 1.002 against ``value <= 1`` is shown
    as 1.002, not 1)."""
    rd = claim.get("rule_def", {})
    digits = rd.get("digits", 3)
    try:
        thr = Rule(**rd).thresholds(metrics) if rd.get("value") else []
    except (RuleError, TypeError):
        thr = []
    return fmt(claim["value"], distinguishing_digits(claim["value"], thr, digits))


def _source_text(claim: dict) -> str:
    rd = claim.get("rule_def", {})
    if rd.get("source"):
        return rd["source"]
    return "no threshold (nothing to compare with)" if rd.get("reproduced") is None else ""


def _cell(x) -> str:
    return str(x).replace("|", "/").replace("\n", " ")


def _claim_row(nb: str, c: dict, metrics: dict, ref: str = "") -> str:
    """One table row; the rule, the threshold's origin and the note go to the numbered
    list below the table (:func:`_claim_details`), ``ref`` names the entry."""
    fig = c["figure"]
    link = f"[{fig}](figures/{nb}/{fig}.png)" if fig else ""
    verdict = f"**{c['verdict']}**"
    if c.get("duplicate_of"):
        verdict += " (duplicate, not counted)"
    if c.get("proves_little"):
        verdict += " (holds but proves little)"
    cells = [c["paper"], c["item"], link, c["metric"], claim_value_text(c, metrics), c["target"],
             verdict, ref]
    return "| " + " | ".join(_cell(x) for x in cells) + " |"


def _claim_details(ref: str, c: dict, refs_of: dict | None = None) -> list[str]:
    """The list entry ``ref`` of a claim: its rule, where the thresholds come from, its note
    (one line each, so no line of REPRODUCTION.md is a paragraph); for a duplicate, where the
    claim is counted."""
    out = [f"- {ref} rule: {_cell(c.get('rule', ''))}"]
    if c.get("duplicate_of"):
        nb, _, item = c["duplicate_of"].partition(":")
        where = (refs_of or {}).get((nb.strip(), item.strip()), "")
        out.append(f"  - same claim as {where or _cell(c['duplicate_of'])} "
                   f"({_cell(c['duplicate_of'])}): listed, not counted again")
    if _source_text(c):
        out.append(f"  - threshold from: {_cell(_source_text(c))}")
    if c.get("note"):
        out.append(f"  - note: {_cell(c['note'])}")
    return out


def paper_of(claim: dict) -> str:
    """The paper a claim belongs to, ``"Author Year"`` (the text of its ``paper`` field before
    any parenthesis or semicolon: ``"El Youssfi 2020 (relaxed UIO)"`` -> ``"El Youssfi 2020"``)."""
    return re.split(r"\s*[(;]", claim["paper"], maxsplit=1)[0].strip()


def distinct(claims: list[dict]) -> list[dict]:
    """The claims that are not a duplicate of a claim graded elsewhere (``duplicate_of``)."""
    return [c for c in claims if not c.get("duplicate_of")]


def paper_tally_table(paper_rows: list[tuple[str, dict]]) -> list[str]:
    """Markdown table of the distinct paper claims per paper: one row per paper, its
    notebooks and its count per verdict (duplicates are not counted again)."""
    papers = sorted({paper_of(c) for _, c in paper_rows})
    head = ["| paper | notebooks | distinct claims | " + " | ".join(VERDICTS) + " |",
            "|---|---|---|" + "---|" * len(VERDICTS)]
    rows = []
    for p in papers:
        sel = [(nb, c) for nb, c in paper_rows if paper_of(c) == p]
        cl = distinct([c for _, c in sel])
        cells = []
        for v in VERDICTS:
            n = [c for c in cl if c["verdict"] == v]
            weak = sum(bool(c.get("proves_little")) for c in n)
            cells.append(f"{len(n)}" + (f" ({weak} prove little)" if weak else ""))
        nbs = ", ".join(dict.fromkeys(nb[:2] for nb, _ in sel))
        rows.append(f"| {p} | {nbs} | {len(cl)} | " + " | ".join(cells) + " |")
    return head + rows


def report_notebook(nb: str, root: Path) -> str:
    """Where a section's claims are computed: its report notebook if there is one."""
    rep = root / "notebooks" / "reports" / f"{nb}_report.ipynb"
    return f"notebooks/reports/{nb}_report.ipynb" if rep.exists() else f"notebooks/{nb}.ipynb"


def write_reproduction(figures_dir: Path, out: Path, root: Path | None = None) -> Path:
    """Build REPRODUCTION.md from every ``figures/*/metrics.json``: the paper claims first,
    with their own tally per paper and per notebook (a claim marked ``duplicate_of`` is listed
    with a reference to where it is graded and counted once), then the benchmark targets,
    diagnostics, baselines and data checks in separate tables with their own counts (never
    added to the paper claims), then every notebook's metrics."""
    root = root or repo_root()
    docs = [json.loads(mj.read_text()) for mj in sorted(figures_dir.glob("*/metrics.json"))]
    docs = [d for d in docs if "notebook" in d]
    values = {d["notebook"]: {k: v["value"] for k, v in d["metrics"].items()} for d in docs}
    by_kind = {k: [(d["notebook"], c) for d in docs for c in d["claims"] if _kind(c) == k]
               for k in KINDS}
    paper = distinct([c for _, c in by_kind["paper"]])
    dups = len(by_kind["paper"]) - len(paper)
    apart = [f"{_count(len(by_kind[k]), k)} ({tally([c for _, c in by_kind[k]], zeros=False)})"
             for k in KINDS if k != "paper" and by_kind[k]]
    summary = (f"Summary: {len(paper)} distinct paper claims: {tally(paper)}." if paper
               else "Summary: no paper claims yet.")
    if dups:
        summary += f" {dups} more rows grade a claim already counted (listed, not counted again)."
    if apart:
        summary += " Counted apart, not paper claims: " + "; ".join(apart) + "."
    lines = ["# Reproduction status", "",  # prose wrapped below (no paragraph-long line)
             "Generated by `make figures` from the claims each section's reproduction report "
             "records (`notebooks/reports/`, written to `figures/<notebook>/metrics.json`); do "
             "not edit by hand. The lessons (`notebooks/NN_*.ipynb`) teach; the reports hold "
             "the bookkeeping below.", "",
             "Each verdict is computed from its rule (`results/rules.py`, listed below each table): "
             "the rule's "
             "expression over the run's metrics gives the value; **reproduced** if the "
             "reproduced-condition holds, else **partly** if the partly-condition holds, else "
             "**differs**; **not comparable** where the paper prints no number or behaviour to "
             "test. \"Holds but proves little\" marks a check that passes without telling much "
             "(its informative-condition fails). \"Threshold from\" says whether a rule's "
             "numbers are the paper's (\"paper:\") or chosen in this repository (\"chosen "
             "here:\", with the reason). A value close to a threshold is shown with enough "
             "digits to tell on which side it lies.", "",
             "Only the claims printed in the papers are counted as the reproduction, each "
             "distinct claim once: a row that grades a claim already graded in another notebook "
             "names that row and is not counted again. Benchmark targets, diagnostics, baselines "
             "and data checks are tabled and counted apart.", "",
             summary, ""]
    lines = [textwrap.fill(x, 100, break_long_words=False, break_on_hyphens=False)
             if len(x) > 100 and not x.startswith(("|", "#", "Summary:")) else x for x in lines]
    if by_kind["paper"]:
        lines += ["## Distinct paper claims per paper", "", *paper_tally_table(by_kind["paper"]), "",
                  "Per notebook (distinct claims; duplicates in brackets):", ""]
        for nb in dict.fromkeys(nb for nb, _ in by_kind["paper"]):
            sel = [c for n, c in by_kind["paper"] if n == nb]
            d = len(sel) - len(distinct(sel))
            lines.append(f"- {nb}: {len(distinct(sel))} ({tally(distinct(sel), zeros=False) or 'none'})"
                         + (f" [{d} duplicate{'s' if d > 1 else ''}]" if d else ""))
        lines.append("")
    refs_of: dict[tuple[str, str], str] = {}
    for kind, title in KINDS.items():
        rows = by_kind[kind]
        if not rows:
            continue
        counted = distinct([c for _, c in rows])
        lines += [f"## {title[0].upper() + title[1:]}", "", KIND_INTROS[kind], "",
                  f"{_count(len(counted), kind)}: {tally(counted, zeros=kind == 'paper')}.",
                  ""]
        for nb in dict.fromkeys(nb for nb, _ in rows):
            lines += [f"### {title[0].upper() + title[1:]}: {nb}", "", *TABLE_HEADER]
            sel = [c for n, c in rows if n == nb]
            refs = [f"[{kind[0]}{nb[:2]}.{i + 1}]" for i in range(len(sel))]
            for c, r in zip(sel, refs):
                refs_of[(nb, c["item"])] = r
            lines += [_claim_row(nb, c, values[nb], r) for c, r in zip(sel, refs)]
            lines.append("")
            for c, r in zip(sel, refs):
                lines += _claim_details(r, c, refs_of)
            lines.append("")
    for d in docs:
        nb = d["notebook"]
        mode = " (quick mode)" if d.get("quick") else ""
        counts = ", ".join(_count(n, k) for k in KINDS
                           if (n := sum(_kind(c) == k for c in d["claims"])))
        lines += [f"## {nb}{mode}", "", f"Report: `{report_notebook(nb, root)}`, seed {d.get('seed')}; "
                  f"claims: {counts or 'none'}.", ""]
        if d["metrics"]:
            lines += ["<details><summary>all metrics</summary>", "",
                      "| metric | value | unit |", "|---|---|---|"]
            for k, v in d["metrics"].items():
                lines.append(f"| {k} | {fmt(v['value'], 4)} | {v.get('unit', '')} |")
            lines += ["", "</details>", ""]
    out.write_text("\n".join(lines) + "\n")
    return out


def _run_one(job) -> tuple[float, str | None]:
    """Run one notebook (a worker of :func:`main`): ``(seconds, None)``, or ``(seconds, "cell
    N: Error: message")`` when a cell fails (papermill's error reduced to a picklable line)."""
    nb, out, figures, seed, quick, timeout, kernel = job
    t0 = time.perf_counter()
    try:
        run_notebook(nb, out, figures, seed=seed, quick=quick, timeout=timeout, kernel=kernel)
    except Exception as exc:  # papermill wraps cell errors; report the cell
        cell = getattr(exc, "cell_index", None)
        ename = getattr(exc, "ename", type(exc).__name__)
        evalue = getattr(exc, "evalue", str(exc))
        where = f"cell {cell}" if cell is not None else "execution"
        return time.perf_counter() - t0, f"{where}: {ename}: {evalue}"
    return time.perf_counter() - t0, None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("--quick", action="store_true", help="short horizons (tests)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", default="", help="comma-separated notebook prefixes, e.g. 01,03")
    ap.add_argument("--figures", default="figures")
    ap.add_argument("--build", default="build/notebooks")
    ap.add_argument("--timeout", type=int, default=1200, help="per-cell timeout [s]")
    ap.add_argument("--html", default="", help="also render the executed copies to HTML here")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1),
                    help="notebooks run at once, each in its own kernel (default: 2, or 1 on one "
                         "core); the results do not depend on it")
    args = ap.parse_args(argv)

    root = repo_root()
    figures = (root / args.figures) if not Path(args.figures).is_absolute() else Path(args.figures)
    build = (root / args.build) if not Path(args.build).is_absolute() else Path(args.build)
    # lessons first, then reports: a section's lesson and report never run at the same time
    nbs = sorted(notebooks(root), key=lambda nb: (notebook_kind(nb) != "lesson", nb.name))
    if args.only:
        wanted = tuple(x.strip() for x in args.only.split(",") if x.strip())
        nbs = [nb for nb in nbs if nb.name.startswith(wanted)]
    if not nbs:
        print("no notebooks selected", file=sys.stderr)
        return 2
    kernel = kernel_name()
    if args.jobs < 1:
        print(f"--jobs must be >= 1, got {args.jobs}", file=sys.stderr)
        return 2
    jobs = [(nb, build / nb.name, figures, args.seed, args.quick, args.timeout, kernel) for nb in nbs]
    if args.jobs == 1 or len(nbs) == 1:
        results = map(_run_one, jobs)
    else:
        from concurrent.futures import ProcessPoolExecutor
        from multiprocessing import get_context

        pool = ProcessPoolExecutor(max_workers=args.jobs, mp_context=get_context("spawn"))
        results = pool.map(_run_one, jobs)
    times, failed = {}, []
    for nb, (seconds, error) in zip(nbs, results):
        if error:
            failed.append(f"FAILED: notebook {nb.name}, {error}\nexecuted copy kept at {build / nb.name}")
            print(f"  {nb.stem:<32} FAILED", flush=True)
        else:
            times[nb.stem] = seconds
            print(f"  {nb.stem:<32} done ({len(times) + len(failed)}/{len(nbs)})", flush=True)
    if args.jobs > 1 and len(nbs) > 1:
        pool.shutdown()
    if failed:
        print("\n" + "\n".join(failed), file=sys.stderr)
        return 1
    if args.html:
        html = Path(args.html) if Path(args.html).is_absolute() else root / args.html
        for p in write_html([build / nb.name for nb in nbs], html):
            print(f"wrote {p}")
    for k, v in times.items():
        print(f"  {k:<32} {v:7.1f} s")
    if not args.only and not args.quick and figures.resolve() == (root / "figures").resolve():
        p = write_reproduction(figures, root / "REPRODUCTION.md", root)
        print(f"wrote {p.relative_to(root)}")
    else:
        print("REPRODUCTION.md not written (only a full run of every notebook into the "
              "repository's figures/ writes it)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
