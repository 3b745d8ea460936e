"""A campaign's report: the merged table, per stream the navigation measures against each axis
with 95 % confidence intervals (bootstrap over cases), charts, and a summary of which stream to
fly in which conditions.

Tables have a row per stream (baselines last) and a column per value of the axis, per
trajectory. Charts: availability and attitude RMS against the phase angle, one line per stream
when there are at most eight, else the cameras, the adaptive policy and each method's flight
variant, with a heat map per trajectory that shows every stream.

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
#: Up to this many streams every one is a line in the charts; with more, the HEADLINE ones are
#: and a heat map per trajectory shows them all.
MAX_LINES = 8
HEADLINE = ("vis", "tir", "adaptive", "adf-flight", "tsifsd-flight", "ifevip-flight")


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


def _headline(streams: Sequence[str]) -> List[str]:
    """The streams drawn as lines: all of them when few, else the cameras, the adaptive policy
    and each method's flight variant (the heat maps show every stream)."""
    if len(streams) <= MAX_LINES:
        return list(streams)
    return [s for s in HEADLINE if s in streams]


def _charts(df, streams: Sequence[str], out: Path) -> List[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths: List[Path] = []
    if df["sun_phase_deg"].isna().all():
        return paths
    earths = sorted(df["earth"].unique())
    lines = _headline(streams)
    colours = plt.get_cmap("tab10")
    for traj in sorted(df["trajectory"].unique()):
        for col, label, _ in MEASURES[:2]:
            fig, axes = plt.subplots(1, len(earths), figsize=(5.6 * len(earths) + 2.2, 4.4), squeeze=False, sharey=True)
            for ax, earth in zip(axes[0], earths):
                sub = df[(df.trajectory == traj) & (df.earth == earth)]
                for k, s in enumerate(lines):
                    rows = sub[sub.source == s]
                    xs, ms, los, his = [], [], [], []
                    for x, g in rows.groupby("sun_phase_deg"):
                        m, lo, hi = bootstrap_mean(g[col].to_numpy(dtype=float))
                        xs.append(x)
                        ms.append(m)
                        los.append(lo)
                        his.append(hi)
                    if xs:
                        ax.plot(xs, ms, marker="o", label=s, color=colours(k % 10))
                        ax.fill_between(xs, los, his, color=colours(k % 10), alpha=0.12)
                ax.set_title(f"{traj}, {'the Earth behind the target' if earth else 'black space'}")
                ax.set_xlabel("sun phase angle at the first frame (°)")
                ax.grid(True, alpha=0.3)
                if col == "att_rms_deg":
                    ax.set_yscale("log")
            axes[0][0].set_ylabel(f"{label}, mean over cases (band: 95 % CI)")
            axes[0][-1].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
            fig.tight_layout()
            path = out / f"{traj}_{col}.png"
            write_atomic(path, lambda t: fig.savefig(t, dpi=110, format="png"))
            plt.close(fig)
            paths.append(path)
        if len(lines) < len(streams):
            paths.append(_heatmap(df[df.trajectory == traj], streams, earths, traj, out, plt))
    return paths


def _heatmap(df, streams: Sequence[str], earths, traj: str, out: Path, plt) -> Path:
    """Every stream's mean availability against the phase angle, one panel per background."""
    angles = sorted(df["sun_phase_deg"].dropna().unique())
    panel = max(3.2, 0.75 * len(angles))
    fig, axes = plt.subplots(1, len(earths), figsize=(panel * len(earths) + 3.4, 0.32 * len(streams) + 1.8), squeeze=False, sharey=True)
    image = None
    for ax, earth in zip(axes[0], earths):
        sub = df[df.earth == earth]
        grid = np.full((len(streams), len(angles)), np.nan)
        for i, s in enumerate(streams):
            for j, a in enumerate(angles):
                v = sub[(sub.source == s) & (sub.sun_phase_deg == a)]["availability"].to_numpy(dtype=float)
                if v.size:
                    grid[i, j] = float(np.nanmean(v))
        image = ax.imshow(grid, vmin=0.0, vmax=1.0, cmap="viridis", aspect="auto")
        for i in range(len(streams)):
            for j in range(len(angles)):
                if np.isfinite(grid[i, j]):
                    ax.text(j, i, f"{grid[i, j]:.2f}", ha="center", va="center", fontsize=7, color="white" if grid[i, j] < 0.6 else "black")
        ax.set_xticks(range(len(angles)), [f"{a:g}" for a in angles])
        ax.set_yticks(range(len(streams)), list(streams))
        ax.set_title("the Earth behind the target" if earth else "black space")
    fig.suptitle(f"{traj}: navigation availability of every stream")
    fig.supxlabel("sun phase angle at the first frame (°)")
    if image is not None:
        fig.colorbar(image, ax=list(axes[0]), label="navigation availability, mean over cases", fraction=0.03)
    path = out / f"{traj}_availability_every_stream.png"
    write_atomic(path, lambda t: fig.savefig(t, dpi=110, format="png", bbox_inches="tight"))
    plt.close(fig)
    return path


def _best(df, streams: Sequence[str]) -> str:
    """The stream to fly among `streams` on these cases, by availability (paired bootstrap).
    Streams with the leader's availability on every case are named with it (`a ≡ b`) and the
    verdict is against the next one that differs."""
    per = {s: df[df.source == s].set_index("case_id")["availability"].sort_index() for s in streams}
    ranked = sorted(streams, key=lambda s: -float(per[s].mean()))
    best = ranked[0]
    tied = [s for s in ranked[1:] if per[s].equals(per[best])]
    rest = [s for s in ranked[1:] if s not in tied]
    if not rest and len(streams) > 2:
        name = "every stream alike"
    elif len(tied) <= 2:
        name = " ≡ ".join([best, *tied])
    else:
        name = f"{best} ≡ {len(tied)} others"
    mean_best = float(per[best].mean())
    if mean_best < USABLE:
        return f"none navigates (best: {name}, {mean_best:.2f})"
    if not rest:
        return f"{name} ({mean_best:.2f})"
    second = rest[0]
    a, b = per[best].align(per[second], join="inner")
    _, lo, _ = bootstrap_mean((a - b).to_numpy(dtype=float))
    if a.size < MIN_CASES:
        return f"{name} ({mean_best:.2f}; {a.size} cases, too few for a verdict)"
    if lo > 0:
        return f"**{name}** ({mean_best:.2f})"
    return f"{name} ≈ {second} ({mean_best:.2f} vs {float(per[second].mean()):.2f}, not separated)"


def _stream_table(columns: List[Tuple[str, object]], streams: Sequence[str], stat) -> List[str]:
    """A markdown table with a row per stream and a column per (heading, key); `stat(stream,
    key)` gives the cell's (mean, lo, hi)."""
    out = ["| stream | " + " | ".join(h for h, _ in columns) + " |", "|---" * (len(columns) + 1) + "|"]
    for s in streams:
        out.append(f"| {s} | " + " | ".join(_fmt(stat(s, k), 2) for _, k in columns) + " |")
    return out + [""]


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
    streams = sorted(s for s in whole["source"].unique() if s not in BASELINES)
    sources = streams + [s for s in BASELINES if s in set(whole["source"])]
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
    trajectories = sorted(df["trajectory"].unique())
    phases = [ph for ph in ("light", "penumbra", "eclipse") if ph in set(df["phase"])]
    if phases:
        cols = []
        for traj in trajectories:
            for ph in phases:
                g = df[(df.trajectory == traj) & (df.phase == ph)]
                if not g.empty:
                    cols.append((f"{traj}, {ph} ({g.case_id.nunique()} cases)", g))
        lines += ["## By illumination phase", "", "navigation availability (the cases whose sequence passes through the phase):", ""]
        lines += _stream_table(cols, sources, lambda s, g: bootstrap_mean(g[g.source == s]["availability"].to_numpy(dtype=float)))
    # Each axis: a column per value; per trajectory where the trajectory varies too.
    for col, label in axes:
        values = sorted(whole[col].dropna().unique()) if col == "sun_phase_deg" else sorted(whole[col].unique())
        lines += [f"## By {label}", ""]
        split = [None] if col == "trajectory" or len(trajectories) == 1 else trajectories
        for traj in split:
            part = whole if traj is None else whole[whole.trajectory == traj]
            for m, mlabel, _ in MEASURES[:2]:
                lines += [f"{mlabel}{'' if traj is None else f', {traj}'}:", ""]

                def stat(s, v, part=part, m=m, traj=traj):
                    g = part[(part[col] == v) & (part.source == s)]
                    st = bootstrap_mean(g[m].to_numpy(dtype=float))
                    key = _value(v) if traj is None else f"{traj}, {_value(v)}"
                    summary["by_axis"].setdefault(col, {}).setdefault(key, {}).setdefault(s, {})[m] = st
                    return st

                lines += _stream_table([(f"{label} {_value(v)}", v) for v in values], sources, stat)
    # Which stream to fly, per condition.
    keys = [c for c in ("trajectory", "earth", "target", "glare", "sun_phase_deg") if whole[c].nunique(dropna=False) > 1 or c == "trajectory"]
    lines += [
        "## Which stream to fly",
        "",
        "Per condition, the stream with the highest mean availability; in bold where the paired bootstrap "
        "interval of its difference to the runner-up (the same cases) lies above zero, else both named "
        "(`a ≡ b`, `a ≡ N others`: the same availability on every case, one stream for this choice); "
        f"no verdict on fewer than {MIN_CASES} cases; none where even the best keeps navigation on "
        f"less than {USABLE:.0%} of the frames.",
        "",
    ]
    # With many streams (a method's variants side by side) also the choice of method: the
    # cameras, the adaptive policy and each method's flight variant.
    headline = _headline(streams)
    choices = [("every stream", streams)] + ([("one per method", headline)] if len(headline) < len(streams) else [])
    if len(choices) > 1:
        lines += [f"*one per method*: among {', '.join(headline)} only.", ""]
    lines += [
        "| " + " | ".join(dict(AXES)[k] for k in keys) + " | " + " | ".join(f"to fly, {c} (availability)" for c, _ in choices) + " |",
        "|---" * (len(keys) + len(choices)) + "|",
    ]
    wins: List[Dict[str, int]] = [{} for _ in choices]
    for cond, g in whole.groupby(keys, dropna=False):
        cond = cond if isinstance(cond, tuple) else (cond,)
        verdicts = [_best(g, among) for _, among in choices]
        for w, verdict in zip(wins, verdicts):
            if verdict.startswith("**"):
                name = verdict[2:].split("**")[0]
                w[name] = w.get(name, 0) + 1
        lines.append("| " + " | ".join(_value(v) for v in cond) + " | " + " | ".join(verdicts) + " |")
    n_cond = whole.groupby(keys, dropna=False).ngroups
    lines.append("")
    for (label, _), w in zip(choices, wins):
        lines.append(
            f"Separated winners ({label}): "
            + (", ".join(f"{s} in {n} of {n_cond} conditions" for s, n in sorted(w.items(), key=lambda x: -x[1])) or "none")
            + f"; in the other {n_cond - sum(w.values())} no stream is separated from the runner-up."
        )
    lines.append("")
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
