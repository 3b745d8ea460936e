"""A campaign's report: the merged table, per stream the navigation measures against each axis
with 95 % confidence intervals (bootstrap over cases), charts, and a summary of which stream to
fly in which conditions.

The intervals resample cases (2000 resamples, a fixed seed, so the report is reproducible).
A stream is called the one to fly in a condition only where the paired bootstrap interval of
its difference to the runner-up (the same cases judged by both) excludes zero; otherwise the
report names both and says they are not separated.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Dict, List, Sequence, Tuple

import numpy as np

from .store import CampaignError, Store, write_atomic

#: The figures reported: column, label, whether higher is better.
MEASURES: List[Tuple[str, str, bool]] = [
    ("availability", "navigation availability", True),
    ("att_rms_deg", "attitude RMS (°)", False),
    ("pos_rms_pct", "position RMS (% of range)", False),
    ("rot_err_deg_median", "frame-to-frame rotation error, median (°)", False),
    ("lost_frac", "frame pairs lost", False),
    ("nees", "NEES (6 when consistent)", False),
]
#: The axes a campaign may vary, in the order the report walks them.
AXES: List[Tuple[str, str]] = [
    ("trajectory", "trajectory"),
    ("sun_phase_deg", "sun phase angle (°)"),
    ("earth", "Earth behind the target"),
    ("target", "target"),
    ("glare", "glare"),
]
BASELINES = ("zero-motion", "oracle")
RESAMPLES = 2000
#: Fewest cases of a condition for a verdict on it (a bootstrap of fewer says little).
MIN_CASES = 5
#: Below this mean availability no stream is named to fly: every one has lost navigation.
USABLE = 0.10


def bootstrap_mean(values: np.ndarray, seed: int = 0) -> Tuple[float, float, float]:
    """Mean and 95 % percentile-bootstrap interval of the mean (NaN dropped)."""
    v = values[np.isfinite(values)]
    if v.size == 0:
        return (float("nan"),) * 3
    if v.size == 1:
        return float(v[0]), float(v[0]), float(v[0])
    rng = np.random.default_rng(seed)
    means = v[rng.integers(0, v.size, size=(RESAMPLES, v.size))].mean(axis=1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return float(v.mean()), float(lo), float(hi)


def _fmt(m: Tuple[float, float, float], digits: int = 3) -> str:
    mean, lo, hi = m
    if not np.isfinite(mean):
        return "—"
    return f"{mean:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def _value(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:g}"
    return str(v)


def _charts(df, streams: Sequence[str], out: Path) -> List[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths: List[Path] = []
    if df["sun_phase_deg"].isna().all():
        return paths
    earths = sorted(df["earth"].unique())
    for traj in sorted(df["trajectory"].unique()):
        for col, label, _ in MEASURES[:2]:
            fig, axes = plt.subplots(1, len(earths), figsize=(6.2 * len(earths), 4.4), squeeze=False, sharey=True)
            for ax, earth in zip(axes[0], earths):
                sub = df[(df.trajectory == traj) & (df.earth == earth)]
                for s in streams:
                    rows = sub[sub.source == s]
                    xs, ms, los, his = [], [], [], []
                    for x, g in rows.groupby("sun_phase_deg"):
                        m, lo, hi = bootstrap_mean(g[col].to_numpy(dtype=float))
                        xs.append(x)
                        ms.append(m)
                        los.append(lo)
                        his.append(hi)
                    if xs:
                        line = ax.plot(xs, ms, marker="o", label=s)[0]
                        ax.fill_between(xs, los, his, color=line.get_color(), alpha=0.15)
                ax.set_title(f"{traj}, {'the Earth behind the target' if earth else 'black space'}")
                ax.set_xlabel("sun phase angle at the first frame (°)")
                ax.grid(True, alpha=0.3)
                if col == "att_rms_deg":
                    ax.set_yscale("log")
            axes[0][0].set_ylabel(f"{label}, mean over cases (band: 95 % CI)")
            axes[0][-1].legend(fontsize=8)
            fig.tight_layout()
            path = out / f"{traj}_{col}.png"
            write_atomic(path, lambda t: fig.savefig(t, dpi=110, format="png"))
            plt.close(fig)
            paths.append(path)
    return paths


def _best(df, streams: Sequence[str]) -> str:
    """The stream to fly among `streams` on these cases, by availability (paired bootstrap)."""
    per = {s: df[df.source == s].set_index("case_id")["availability"] for s in streams}
    ranked = sorted(streams, key=lambda s: -float(per[s].mean()))
    best, second = ranked[0], ranked[1] if len(ranked) > 1 else None
    if second is None:
        return best
    a, b = per[best].align(per[second], join="inner")
    _, lo, _ = bootstrap_mean((a - b).to_numpy(dtype=float))
    mean_best = float(per[best].mean())
    if mean_best < USABLE:
        return f"none navigates (best: {best}, {mean_best:.2f})"
    if a.size < MIN_CASES:
        return f"{best} ({mean_best:.2f}; {a.size} cases, too few for a verdict)"
    if lo > 0:
        return f"**{best}** ({mean_best:.2f})"
    return f"{best} ≈ {second} ({mean_best:.2f} vs {float(per[second].mean()):.2f}, not separated)"


def report(out) -> Path:
    """Writes DIR/results.parquet (merged), DIR/report.md, DIR/report.json and the charts;
    returns the markdown's path."""
    import pandas as pd

    out = Path(out)
    with Store(out) as store:
        state = store.state()
        if state is None:
            raise CampaignError(f"{out}: not a campaign folder (no campaign.json)")
        records = store.records()
        done = [c for c, r in records.items() if r["status"] == "done"]
        failed = {c: r.get("reason", "") for c, r in records.items() if r["status"] == "failed"}
        if not done:
            raise CampaignError(f"{out}: no finished case to report")
        store.merge(done)
        seconds = [r["seconds"] for r in records.values() if "seconds" in r]
    df = pd.read_parquet(out / "results.parquet")
    whole = df[df.phase == "all"]
    sources = sorted(whole["source"].unique())
    streams = [s for s in sources if s not in BASELINES]
    lines = [
        f"# Campaign `{state['name']}`",
        "",
        f"{len(done)} cases finished of {state['cases']} planned, {len(failed)} failed; plan "
        f"`{state['fingerprint']}`, code `{state['code_version']}`. Streams: {', '.join(streams)}; baselines: "
        f"{', '.join(s for s in sources if s in BASELINES)}.",
    ]
    if seconds:
        lines.append(
            f"Per case (in its worker): median {np.median(seconds):.1f} s, mean {np.mean(seconds):.1f} s, "
            f"{sum(seconds) / 3600:.2f} worker-hours in all."
        )
    lines += [
        "",
        "Every figure: the mean over cases of the whole-sequence figure (phase `all`) with its 95 % "
        "bootstrap interval over cases in brackets. *available*: the share of frames whose attitude error "
        "is ≤ 2° and position error ≤ 2 % of range (`fusion navbench`).",
        "",
    ]
    summary: Dict = {"name": state["name"], "cases": len(done), "failed": failed, "by_axis": {}}
    axes = [(c, label) for c, label in AXES if whole[c].nunique(dropna=False) > 1]
    lines += ["## Every case", "", "| source | cases | " + " | ".join(lbl for _, lbl, _ in MEASURES) + " |"]
    lines.append("|---" * (len(MEASURES) + 2) + "|")
    for s in sources:
        g = whole[whole.source == s]
        cells = [_fmt(bootstrap_mean(g[c].to_numpy(dtype=float)), 2 if c in ("nees", "att_rms_deg", "pos_rms_pct") else 3) for c, _, _ in MEASURES]
        lines.append(f"| {s} | {g.case_id.nunique()} | " + " | ".join(cells) + " |")
    lines.append("")
    # Each illumination phase the sequences pass through (a case counts where its frames fall in it).
    phases = [ph for ph in ("light", "penumbra", "eclipse") if ph in set(df["phase"])]
    if phases:
        lines += ["## By illumination phase", "", "navigation availability (cases whose sequence passes through the phase):", ""]
        lines += ["| trajectory | phase | cases | " + " | ".join(sources) + " |", "|---" * (len(sources) + 3) + "|"]
        for traj in sorted(df["trajectory"].unique()):
            for ph in phases:
                g = df[(df.trajectory == traj) & (df.phase == ph)]
                if g.empty:
                    continue
                cells = [_fmt(bootstrap_mean(g[g.source == s]["availability"].to_numpy(dtype=float)), 2) for s in sources]
                lines.append(f"| {traj} | {ph} | {g.case_id.nunique()} | " + " | ".join(cells) + " |")
        lines.append("")
    for col, label in axes:
        lines += [f"## By {label}", ""]
        for m, mlabel, _ in MEASURES[:2]:
            values = sorted(whole[col].dropna().unique()) if col == "sun_phase_deg" else sorted(whole[col].unique())
            lines += [f"{mlabel}:", "", f"| {label} | " + " | ".join(sources) + " |", "|---" * (len(sources) + 1) + "|"]
            for v in values:
                g = whole[whole[col] == v]
                cells = []
                for s in sources:
                    stat = bootstrap_mean(g[g.source == s][m].to_numpy(dtype=float))
                    cells.append(_fmt(stat, 2))
                    summary["by_axis"].setdefault(col, {}).setdefault(_value(v), {}).setdefault(s, {})[m] = stat
                lines.append(f"| {_value(v)} | " + " | ".join(cells) + " |")
            lines.append("")
    # Which stream to fly, per condition.
    keys = [c for c in ("trajectory", "earth", "target", "glare", "sun_phase_deg") if whole[c].nunique(dropna=False) > 1 or c == "trajectory"]
    lines += [
        "## Which stream to fly",
        "",
        "Per condition, the stream with the highest mean availability; in bold where the paired bootstrap "
        "interval of its difference to the runner-up (the same cases) lies above zero, else both named; "
        f"no verdict on fewer than {MIN_CASES} cases; none where even the best keeps navigation on "
        f"less than {USABLE:.0%} of the frames.",
        "",
        "| " + " | ".join(dict(AXES)[k] for k in keys) + " | stream to fly (availability) |",
        "|---" * (len(keys) + 1) + "|",
    ]
    wins: Dict[str, int] = {}
    for cond, g in whole.groupby(keys, dropna=False):
        cond = cond if isinstance(cond, tuple) else (cond,)
        verdict = _best(g, streams)
        if verdict.startswith("**"):
            name = verdict[2:].split("**")[0]
            wins[name] = wins.get(name, 0) + 1
        lines.append("| " + " | ".join(_value(v) for v in cond) + f" | {verdict} |")
    n_cond = whole.groupby(keys, dropna=False).ngroups
    lines += [
        "",
        "Separated winners: "
        + (", ".join(f"{s} in {n} of {n_cond} conditions" for s, n in sorted(wins.items(), key=lambda x: -x[1])) or "none")
        + f"; in the other {n_cond - sum(wins.values())} no stream is separated from the runner-up.",
        "",
    ]
    charts = _charts(whole, streams, out)
    if charts:
        lines += ["## Charts", ""] + [f"![{p.stem}]({p.name})" for p in charts] + [""]
    if failed:
        lines += ["## Failed cases", "", "| case | reason |", "|---|---|"]
        lines += [f"| `{c}` | {r} |" for c, r in sorted(failed.items())] + [""]
    md = out / "report.md"
    write_atomic(md, lambda t: t.write_text("\n".join(lines)))
    write_atomic(out / "report.json", lambda t: t.write_text(json.dumps(summary, indent=1, default=float) + "\n"))
    return md
