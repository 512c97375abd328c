"""Tables in the paper's layout, Markdown reports and convergence plots."""
from __future__ import annotations

from pathlib import Path

from ..io import atomic
from ..io.atomic import write_json

HEADERS = {"v1": "e(v1)", "v2": "e(v2)", "v3": "e(v3)", "p": "e(p)", "sigma": "e(σ)", "total": "e(v,p,σ)"}


def quantities(records: list[dict]) -> list[str]:
    """The error keys present, in the paper's order (v1, v2[, v3], p, sigma, total)."""
    keys = records[0]["errors"].keys()
    return [k for k in ("v1", "v2", "v3", "p", "sigma", "total") if k in keys]


def _pair(ours, theirs, fmt: str) -> str:
    if ours is None:
        return "—"
    return f"{ours:{fmt}}" if theirs is None else f"{ours:{fmt}} ({theirs:{fmt}})"


def error_table(records: list[dict], reference: list[dict] | None = None, markdown: bool = False) -> str:
    """Errors per level, the paper's values in parentheses where given (Tables 1–4 layout)."""
    ref = {r["level"]: r for r in reference or []}
    keys = quantities(records)
    head = ["level", "vertices", "dofs"] + [HEADERS[k] for k in keys]
    rows = []
    for rec in records:
        theirs = ref.get(rec["level"])
        rows.append([
            str(rec["level"]),
            _pair(rec["vertices"], theirs and theirs["vertices"], "d"),
            _pair(rec["paper_dofs"] if reference else rec["dofs"], theirs and theirs["dofs"], "d"),
        ] + [_pair(rec["errors"][k], theirs and theirs["errors"].get(k), ".6f") for k in keys])
    return _layout(head, rows, markdown)


def rate_table(records: list[dict], reference: list[dict] | None = None, markdown: bool = False) -> str:
    """Rates (76) per pair of levels, the paper's (Tables 5–8) in parentheses."""
    from .study import rates

    theirs = {}
    if reference:
        ref = [dict(r) for r in reference]
        rates(ref, 2)
        theirs = {r["level"]: r["rates"] for r in ref}
    keys = quantities(records)
    head = ["levels"] + [HEADERS[k].replace("e(", "r(") for k in keys]
    rows = []
    for rec in records[1:]:
        other = theirs.get(rec["level"], {})
        rows.append([f"{rec['level'] - 1}→{rec['level']}"] +
                    [_pair(rec["rates"][k], other.get(k), ".3f") for k in keys])
    return _layout(head, rows, markdown)


def time_table(records: list[dict], markdown: bool = False) -> str:
    """Errors per Δt and the rates in Δt (`study.time_rates`) of a time-convergence study."""
    keys = quantities(records)
    head = ["dt"] + [HEADERS[k] for k in keys] + [HEADERS[k].replace("e(", "r(") for k in keys]
    rows = [[f"{rec['dt']:g}"] + [f"{rec['errors'][k]:.3e}" for k in keys]
            + ["-" if rec["rates"][k] is None else f"{rec['rates'][k]:.3f}" for k in keys] for rec in records]
    return _layout(head, rows, markdown)


def _layout(head: list[str], rows: list[list[str]], markdown: bool) -> str:
    if markdown:
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(row) + " |" for row in rows]
        return "\n".join(lines)
    widths = [max(len(r[i]) for r in [head] + rows) for i in range(len(head))]
    fmt = lambda row: "  ".join(cell.rjust(w) for cell, w in zip(row, widths))
    return "\n".join([fmt(head)] + [fmt(row) for row in rows])


def paper_tables(records: list[dict], dt: float, scheme: str) -> str:
    """What ``fsivsp paper`` prints for one Δt: the errors and rates (76) with the paper's (Tables 1–8) in
    parentheses and the estimated backward-Euler floor of e(σ) (``scheme``: the run's time scheme)."""
    from .paper import reference_table, stress_time_floor

    reference = reference_table(dt)
    text = f"Δt = {dt:g}: errors, the paper's in parentheses (Tables 1–4)\n{error_table(records, reference)}"
    if len(records) > 1:
        text += (f"\n\nΔt = {dt:g}: rates (76), the paper's in parentheses (Tables 5–8)\n"
                 f"{rate_table(records, reference)}")
    return (text + f"\n\nestimated backward-Euler floor of e(σ) for this Δt: {stress_time_floor(dt):.4f}"
            + ("" if scheme == "backward_euler" else f" (this run: {scheme})"))


def paper_report(out: Path, results: list[dict], options: dict, wall: float, processes: int,
                 json_path: Path | None = None) -> str:
    """``fsivsp paper --all``'s report.md, convergence.png and results.json (or ``json_path``) in ``out`` from the
    ``results`` of every Δt and level (their rates added here) run with the `paper_case` ``options`` in ``wall``
    seconds on ``processes``; returns the report."""
    from .paper import TIME_STEPS, reference_table, stress_time_floor
    from .study import rates

    series, references = {}, {}
    lines = ["# fsivsp: the experiment of Section 5.3", "",
             f"MINI element, {options['time_scheme'].label}, T = 1; initial stress from the "
             f"{options['initial_stress']}; refinement {'with' if options['project_refinement'] else 'without'} "
             f"projection onto the circle. Wall time {wall:.0f} s on {processes} process(es).", "",
             "Errors with the paper's in parentheses; dofs in the paper's convention.", ""]
    for dt in TIME_STEPS:
        records = sorted((r for r in results if r["dt"] == dt), key=lambda r: r["level"])
        rates(records, 2)
        reference = reference_table(dt)
        label = f"Δt = {dt:g}"
        series[label], references[label] = records, reference
        lines += [f"## {label}", "", error_table(records, reference, markdown=True), "",
                  rate_table(records, reference, markdown=True), "",
                  f"Estimated backward-Euler time-error floor of e(σ): {stress_time_floor(dt):.4f}.", ""]
    lines += ["![convergence](convergence.png)", ""]
    out.mkdir(parents=True, exist_ok=True)
    convergence_plot(series, references, out / "convergence.png")
    report = "\n".join(lines)
    atomic.write_text(out / "report.md", report)
    write_json(json_path or out / "results.json", [r for label in series for r in series[label]])
    return report


def convergence_plot(series: dict[str, list[dict]], references: dict[str, list[dict]], path: str | Path) -> None:
    """Log–log errors against vertices, one panel per unknown, ours solid and the paper's dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first = next(iter(series.values()))
    keys = quantities(first)
    fig, axes = plt.subplots(1, len(keys), figsize=(4 * len(keys), 3.6), constrained_layout=True)
    for ax, key in zip(axes, keys):
        for i, (label, records) in enumerate(series.items()):
            color = f"C{i}"
            ax.loglog([r["vertices"] for r in records], [r["errors"][key] for r in records], "o-", color=color,
                      label=label)
            ref = references.get(label)
            if ref:
                ax.loglog([r["vertices"] for r in ref], [r["errors"][key] for r in ref], "x--", color=color, alpha=0.6)
        n = [r["vertices"] for r in first]
        e0 = first[0]["errors"][key]
        ax.loglog(n, [e0 * (m / n[0]) ** -0.5 for m in n], ":", color="gray", label="slope h¹")
        ax.set_title(HEADERS[key])
        ax.set_xlabel("vertices")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("fsivsp (solid) vs González & Selgas 2018 (dashed)")
    with atomic.replacing(path) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
