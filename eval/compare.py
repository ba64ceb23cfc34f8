"""``python -m eval compare``: tables and convergence plots across harness records, grouped
by task, objective and condition (a panel each) and by the rest of their job's configuration (a
row and a curve each; only the seeds differ within one). What it writes: :data:`DESCRIPTION`.
"""

from __future__ import annotations

import argparse
import math
import sys
import textwrap
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.records import Record
from agents.store import read_record_files
from eval.figures import FORMATS, figure_path, method_label, plt, save, series_style
from tandem_env.io.files import output_directory, write_csv_atomic, write_text_atomic

NAME = "compare"
HELP = "compare records: median/IQR/spread table (CSV, Markdown) and convergence plot (PNG)"
DESCRIPTION = """\
Compare harness records (the records/<key>.json files of `optimize` and `study`) found
recursively in the given directories, grouped by their full job configuration (only seeds
differ within a row; the settings that tell the rows of one condition apart are shown beside
the method). A record failing its checksum or of an earlier format is left out with a warning.
Writes into --out (default: the first DIR's compare/ sub-folder; docs/harness.md, "compare"):
  comparison.csv, comparison.md  per task/objective/condition and configuration: median, IQR
                                 and spread of the objective over the seeds, best, feasible
                                 share, evaluations, wall time, polish gain, KKT residual and
                                 score ("n/a (none feasible)" where no seed flies);
  convergence.png                best-so-far reward against evaluations (median over seeds,
                                 IQR band), one panel per task/objective/condition; a marker
                                 is the median reported objective, a dotted segment the local
                                 polish (--format svg or pdf: convergence.svg, .pdf)."""
EPILOG = """\
example:
  python -m eval compare results/v1.5                 # writes results/v1.5/compare/
  python -m eval compare results/a results/b --out results/ab"""

#: Sub-folder of the first DIR that receives the outputs when --out is not given.
DEFAULT_OUT = "compare"

#: Legend entry of the dotted segment from the end of a search to its polished result.
POLISH_LABEL = "local polish (to the median evaluations spent)"

TABLE_CSV = "comparison.csv"
TABLE_MD = "comparison.md"
PLOT_STEM = "convergence"


@dataclass(frozen=True)
class Row:
    """One configuration on one task/objective/condition over its seeds; its fields but
    :attr:`distinct` are the columns of ``comparison.csv``."""

    task: str
    objective_name: str
    condition: str
    condition_value: float
    condition_unit: str
    method: str
    budget: int
    settings: str
    """The configuration besides method and budget (env keywords, method settings, preset,
    version), ``name=value`` joined by ``; `` (empty if none)."""
    distinct: str
    """The part of ``settings`` that tells this row from the others of its condition."""
    seeds: int
    objective_median: float
    objective_q25: float
    objective_q75: float
    objective_iqr: float
    objective_spread: float
    """(max - min) / |median| of the objective over the seeds [-] (NaN if none feasible)."""
    objective_best: float
    objective_median_feasible: float
    """Median objective over the feasible seeds (NaN if none)."""
    reward_median: float
    feasible_share: float
    evaluations_median: float
    wall_time_median_s: float
    polish_gain_median: float = math.nan
    """Median local polish gain over the seeds (records' ``certificate``) [-]; NaN: none."""
    kkt_residual_median: float = math.nan
    """Median first-order optimality residual of the reported strokes [-] (NaN: none known)."""
    score_median: float = math.nan
    """Median normalised score over the seeds (:attr:`agents.records.Record.score`) [-]; NaN
    where the reference table does not apply."""

    def to_dict(self) -> dict[str, Any]:
        """The row's ``comparison.csv`` columns."""
        return {name: value for name, value in asdict(self).items() if name != "distinct"}


PanelKey = tuple[str, str, str, float, str]
"""(task, objective_name, condition name, value, unit)."""
SeriesKey = tuple[str, int, tuple[tuple[str, str], ...]]
"""(method, budget, the rest of the job's configuration as sorted (name, value text) pairs)."""


def series_key(record: Record) -> SeriesKey:
    """Everything of the record's job but its task, condition and seed, plus its version."""
    job = record.job
    # its configuration's env keywords: runs on another backend are the same series
    settings = {f"{k}": _text(v) for k, v in job.configuration()["env_kwargs"].items()}
    settings.update({f"method.{k}": _text(v) for k, v in job.method_config})
    if job.preset:
        settings["preset"] = job.preset
    settings["tandem_env"] = str(record.versions.get("tandem_env", "?"))
    return (job.method, job.budget, tuple(sorted(settings.items())))


def _text(value: Any) -> str:
    return ",".join(map(_text, value)) if isinstance(value, list | tuple) else f"{value}"


def distinct_settings(keys: Sequence[SeriesKey]) -> dict[SeriesKey, str]:
    """What tells each series of one panel from the others: the budget where budgets differ,
    and the settings whose values differ (or are missing in some)."""
    budgets = {budget for _, budget, _ in keys}
    maps = [dict(pairs) for _, _, pairs in keys]
    out = {}
    for key, m in zip(keys, maps, strict=True):
        # method settings are compared among the series of the same method only
        peers = [p for k, p in zip(keys, maps, strict=True) if k[0] == key[0]]
        varying = [
            n
            for among, method in ((maps, False), (peers, True))
            for n in sorted({n for p in among for n in p if n.startswith("method.") == method})
            if len({p.get(n) for p in among}) > 1
        ]
        parts = [f"budget {key[1]}"] if len(budgets) > 1 else []
        parts += [f"{n}={m.get(n, 'default')}" for n in varying]
        out[key] = ", ".join(parts)
    return out


def group(
    records: Sequence[Record], *, quiet: bool = False
) -> dict[PanelKey, dict[SeriesKey, list[Record]]]:
    """Records by panel, then by configuration; a record seen twice (same key: the same job)
    counts once, said on stderr unless ``quiet``."""
    out: dict[PanelKey, dict[SeriesKey, list[Record]]] = defaultdict(lambda: defaultdict(list))
    seen: set[str] = set()
    for record in records:
        if record.key in seen:  # one configuration and seed: the same run, found twice
            if not quiet:
                twice = f"compare: {record.label()} (key {record.key}) found twice"
                print(f"{twice}; the first found is counted", file=sys.stderr)
            continue
        seen.add(record.key)
        c = record.condition
        panel = (record.task, record.objective_name, c.name, c.value, c.unit)
        out[panel][series_key(record)].append(record)
    return {
        key: {k: sorted(v, key=lambda r: r.seed) for k, v in sorted(series.items())}
        for key, series in sorted(out.items())
    }


def relative_spread(values: np.ndarray) -> float:
    """(max − min) / |median| of a set of objectives [-], the spread README and docs quote."""
    values = np.asarray(values, dtype=np.float64)
    median = float(np.median(values))
    return math.nan if median == 0 else float((values.max() - values.min()) / abs(median))


def table_rows(records: Sequence[Record]) -> list[Row]:
    """One :class:`Row` per task/objective/condition and configuration."""
    rows = []
    for key, series in group(records).items():
        distinct = distinct_settings(list(series))
        for skey, runs in series.items():
            method, budget, pairs = skey
            objective = np.array([r.objective for r in runs])
            feasible = np.array([r.feasible for r in runs], dtype=bool)
            # the objective of strokes that do not fly is not a result: left out (NaN)
            q25 = median = q75 = best = spread = median_feasible = math.nan
            kkt = [r.certificate.get("kkt_residual") for r in runs]
            if feasible.any():
                q25, median, q75 = map(float, np.percentile(objective, [25, 50, 75]))
                best, spread = float(objective.max()), relative_spread(objective)
                median_feasible = float(np.median(objective[feasible]))
            rows.append(
                Row(
                    *key,  # task, objective name, condition, its value and unit
                    method=method,
                    budget=budget,
                    settings="; ".join(f"{k}={v}" for k, v in pairs),
                    distinct=distinct[skey],
                    seeds=len(runs),
                    objective_median=median,
                    objective_q25=q25,
                    objective_q75=q75,
                    objective_iqr=q75 - q25,
                    objective_spread=spread,
                    objective_best=best,
                    objective_median_feasible=median_feasible,
                    reward_median=float(np.median([r.reward for r in runs])),
                    feasible_share=float(np.mean(feasible)),
                    evaluations_median=float(np.median([r.evaluations for r in runs])),
                    wall_time_median_s=float(np.median([r.wall_time for r in runs])),
                    polish_gain_median=_median_known([r.certificate.get("gain") for r in runs]),
                    kkt_residual_median=_median_known(kkt),
                    score_median=_median_known([r.score for r in runs]),
                )
            )
    return rows


def _median_known(values: Sequence[float | None]) -> float:
    known = [float(v) for v in values if v is not None and not math.isnan(float(v))]
    return float(np.median(known)) if known else math.nan


def _fmt(value: float, spec: str = ".4g", scale: float = 1.0, unit: str = "") -> str:
    """``scale * value`` formatted by ``spec``, with ``unit``; "n/a" where it is not finite."""
    return f"{scale * value:{spec}}{unit}" if math.isfinite(value) else "n/a"


def comparison_markdown(rows: Sequence[Row]) -> str:
    """The rows as a Markdown table (objective values to 4 significant digits)."""
    header = (
        "| task | objective | condition | method | budget | seeds | median | IQR (25-75 %) "
        "| spread | best | median of feasible | median reward | feasible | median evaluations "
        "| median wall time [s] | median polish gain | median KKT residual | median score |"
    )
    lines = [header, "|" + "---|" * header.count(" | ") + "---|"]
    for r in rows:
        if r.feasible_share > 0:
            objective = (
                f"{_fmt(r.objective_median)} | {_fmt(r.objective_q25)}-"
                f"{_fmt(r.objective_q75)} ({_fmt(r.objective_iqr, '.3g')}) | "
                f"{_fmt(r.objective_spread, '.3g', 100, ' %')} | "
                f"{_fmt(r.objective_best)} | {_fmt(r.objective_median_feasible)}"
            )
        else:
            objective = "n/a (none feasible) | n/a | n/a | n/a | n/a"
        method = (f"{r.method} ({r.distinct})" if r.distinct else r.method).replace("|", "\\|")
        lines.append(
            f"| {r.task} | {r.objective_name} | {r.condition} = {r.condition_value:g} "
            f"{r.condition_unit} | {method} | {r.budget} | {r.seeds} | {objective} | "
            f"{_fmt(r.reward_median)} | {r.feasible_share:.0%} | {r.evaluations_median:g} | "
            f"{r.wall_time_median_s:.3g} | {_fmt(r.polish_gain_median, '+.2f', 100, ' %')} | "
            f"{_fmt(r.kkt_residual_median, '.2g')} | {_fmt(r.score_median)} |"
        )
    notes = [
        "spread = (max - min) / |median| of the objective over the seeds.",
        "score = 100 · objective / the reference optimum at the condition for a stroke that "
        "flies, -100 · min(1, violation) for one that does not (docs/reference.md); n/a where "
        "the reference does not apply.",
    ]
    if any(r.distinct for r in rows):
        notes.append("In brackets: the settings that tell a row from the others of its condition.")
    return "\n".join(lines) + "\n\n" + "\n".join(notes) + "\n"


def convergence_curve(
    runs: Sequence[Record],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(evaluations, q25, median, q75) of the best-so-far reward over the runs' seeds, each
    history a step function on the union of their grids (missing before its first report)."""
    histories = [np.array(r.history, float).reshape(-1, 2) for r in runs]  # (evaluations, best)
    grid = np.unique(np.concatenate([h[:, 0] for h in histories]))
    values = np.full((len(runs), grid.size), np.nan)
    for k, history in enumerate(histories):
        idx = np.searchsorted(history[:, 0], grid, side="right") - 1
        values[k, idx >= 0] = history[idx[idx >= 0], 1]
    values[~np.isfinite(values)] = np.nan
    with np.errstate(all="ignore"):
        q25, median, q75 = np.nanpercentile(values, [25, 50, 75], axis=0)
    return grid, q25, median, q75


def best_so_far_figure(records: Sequence[Record]) -> Any:
    """The best-so-far figure, a panel per task/objective/condition: each configuration's
    median best-so-far reward over its seeds (band: IQR) and, as a marker, the table's median
    reported objective over the feasible seeds."""
    panels = group(records, quiet=True)  # duplicates are reported by table_rows
    n = len(panels)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.3 * rows), squeeze=False)
    for ax, (key, series) in zip(axes.flat, panels.items(), strict=False):
        task, objective_name, condition, value, unit = key
        distinct = distinct_settings(list(series))
        variant: dict[str, int] = defaultdict(int)
        finals = []
        polished = False
        for skey, runs in series.items():
            method = skey[0]
            style = series_style(method, variant[method])
            colour = style["color"]
            variant[method] += 1
            x, q25, median, q75 = convergence_curve(runs)
            label = ", ".join(p for p in (method_label(method), distinct[skey]) if p)
            label += f" ({len(runs)} seed{'s' * (len(runs) != 1)})"
            ax.plot(x, median, drawstyle="steps-post", color=colour, ls=style["ls"], label=label)
            ax.fill_between(x, q25, q75, step="post", alpha=0.2, color=colour, lw=0)
            if feasible := [r.objective for r in runs if r.feasible]:
                reported = float(np.median(feasible))
                # The search's history ends at its share of the budget; the polish spends the
                # rest: the marker sits at the runs' median total evaluations, joined to the
                # end of the search's curve by the polish segment.
                end = max(float(np.median([r.evaluations for r in runs])), float(x[-1]))
                if end > x[-1]:
                    ax.plot([x[-1], end], [median[-1], reported], ":", color=colour, lw=1.4)
                    polished = True
                ax.plot([end], [reported], marker="D", color=colour, ms=6, mec="k", ls="none")
                finals.append(reported)
            ends = (q25[-1], median[-1], q75[-1], *median[x >= 0.1 * x[-1]][:1])
            finals.extend(v for v in ends if np.isfinite(v))
        reported = f"reported {objective_name} (median of feasible seeds)"
        ax.plot([], [], marker="D", color="0.5", mec="k", ls="none", label=reported)
        if polished:
            ax.plot([], [], ":", color="0.5", lw=1.4, label=POLISH_LABEL)
        if finals:
            # Early rewards of infeasible strokes are far below the feasible objectives at the
            # end: show the range from a tenth of the run on, so the end is readable.
            low, high = min(finals), max(finals)
            pad = 0.08 * (high - low) if high > low else 0.05 * max(abs(high), 1e-3)
            ax.set_ylim(low - pad, high + pad)
        ax.set_title(f"{task}, {objective_name}, {condition} = {value:g} {unit}", fontsize=10)
        ax.set(xlabel="model evaluations", ylabel="best reward so far (penalised objective)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    caption = (
        "Curves: best reward the search saw, feasible or not (median over seeds, band = IQR). "
        "Markers: the reported objective (best feasible stroke, polished and re-evaluated) at "
        "the evaluations spent; dotted: the local polish after the search."
    )
    fig.suptitle(textwrap.fill(caption, 62 * cols), fontsize=9)
    fig.tight_layout()
    return fig


def compare(
    directories: Sequence[str | Path], out: str | Path, figure_format: str = FORMATS[0]
) -> list[Row]:
    """Write the table and plot (``figure_format``) of the records under ``directories``."""
    plot_path = figure_path(Path(out), PLOT_STEM, figure_format)  # a bad format fails first
    if not (records := read_record_files(directories)):
        raise ValueError(
            f"no harness records found in {', '.join(map(str, directories))} (JSON files "
            "written by `python -m eval optimize`)"
        )
    out = Path(out)
    rows = table_rows(records)
    write_csv_atomic(out / TABLE_CSV, [r.to_dict() for r in rows])
    write_text_atomic(out / TABLE_MD, comparison_markdown(rows))
    save(best_so_far_figure(records), plot_path, crop=False)
    return rows


def default_out(directories: Sequence[str | Path]) -> Path:
    """Where the outputs go without --out: ``<first DIR>/compare`` (beside a record file)."""
    first = Path(directories[0])
    return (first.parent if first.is_file() else first) / DEFAULT_OUT


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("dirs", nargs="+", metavar="DIR", help="directories (or files) of records")
    text = f"directory for the outputs (default: the first DIR's {DEFAULT_OUT}/ sub-folder)"
    parser.add_argument("--out", default=None, metavar="OUT", help=text)
    text = f"file format of the convergence figure (default {FORMATS[0]})"
    parser.add_argument("--format", choices=FORMATS, default=FORMATS[0], help=text)


def main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    out = Path(args.out) if args.out is not None else default_out(args.dirs)
    try:
        output_directory(out if args.out is None else args.out)  # before reading any record
        rows = compare(args.dirs, out, args.format)
    except ValueError as error:
        parser.error(str(error))
    sys.stdout.write(comparison_markdown(rows))
    print(f"wrote {out / TABLE_CSV}, {TABLE_MD} and {PLOT_STEM}.{args.format}", file=sys.stderr)
    return 0
