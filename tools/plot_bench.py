#!/usr/bin/env python3
"""Tables and PNG charts from the solver-core benchmark's JSON (build/bench/*.json).

No timing happens here: everything comes from the JSON written by bench/core_bench.cpp.
`table` needs only the standard library; `plots` needs matplotlib (scripts/plots runs it from
the private venv .deps/venv that `scripts/setup --plots` creates).

  tools/plot_bench.py table DIR               print the tables and the headline checks
  tools/plot_bench.py robots-table DIR        the real-arm table (robots.json, bench/robots_bench.cpp)
                                              as Markdown, as docs/benchmarks.md shows it
  tools/plot_bench.py body-table DIR          the body replay (body.json, bench/body_bench.cpp) as Markdown:
                                              one row per clip x solver x start, then the joint ranges
  tools/plot_bench.py plots DIR --out IMG_DIR  write IMG_DIR/*.png (robots.png / body.png too when
                                              robots.json / body.json are there)
"""
import argparse
import json
import math
import os
import sys

COLORS = {
    "two_bone": "#8c564b",
    "ccd": "#1f77b4",
    "fabrik": "#ff7f0e",
    "jacobian_pinv": "#2ca02c",
    "dls": "#d62728",
    "dls_no_posture": "#e377c2",  # the body bench's DLS without the rig's posture task
    "bfgs": "#9467bd",
    "kdl_lma": "#555555",
    "kdl_nr_jl": "#aaaaaa",
}
ORDER = ["two_bone", "ccd", "fabrik", "jacobian_pinv", "dls", "bfgs", "kdl_lma", "kdl_nr_jl"]
# The lecture's precision table (distance to a target 2 beyond reach; optimal 2).
LECTURE = [("lecture JI", 5.85), ("lecture CCD", 3.37), ("lecture BFGS", 2.53)]
SUCCESS_FOR_BEST = 0.99  # "best" = fastest median among solvers at least this reliable


def load(directory, name):
    with open(os.path.join(directory, name), encoding="utf-8") as f:
        return json.load(f)


def solvers_in(records):
    names = {r["solver"] for r in records}
    return [s for s in ORDER if s in names] + sorted(names - set(ORDER))


def finite(v):
    return isinstance(v, (int, float)) and math.isfinite(v)


# ----------------------------------------------------------------------------------- tables

def fmt_us(v):
    if not finite(v):
        return "-"
    return f"{v:.3g}" if v < 100 else f"{v:.0f}"


def print_grid(title, records, field, fmt):
    joints = sorted({r["joints"] for r in records})
    cells = {(r["solver"], r["joints"]): r for r in records}
    width = 8
    print(title)
    print(f"  {'solver':<14}" + "".join(f"{n:>{width}}" for n in joints))
    for s in solvers_in(records):
        row = f"  {s:<14}"
        for n in joints:
            r = cells.get((s, n))
            row += f"{(fmt(r[field]) if r else ''):>{width}}"
        print(row)
    print()


def headline(core):
    records = core["records"]
    cells = {(r["solver"], r["joints"]): r for r in records}
    lines = []
    for n, target in ((10, 3), (100, 100)):
        ok = [r for r in records
              if r["joints"] == n and r["solver"] != "kdl_lma" and finite(r["median_us"])
              and r["success_rate"] >= SUCCESS_FOR_BEST]
        if ok:
            best = min(ok, key=lambda r: r["median_us"])
            lines.append(f"best at {n} joints: {best['solver']} {best['median_us']:.3g} µs "
                         f"(target ≤ {target} µs; success {100 * best['success_rate']:.1f}%)")
        else:
            lines.append(f"best at {n} joints: none (no ikchain solver reaches "
                         f"{100 * SUCCESS_FOR_BEST:.0f}% success) (target ≤ {target} µs)")
    kdl = cells.get(("kdl_lma", 10))
    if kdl:
        lines.append(f"kdl_lma at 10 joints: {kdl['median_us']:.3g} µs, {kdl['median_iterations']:g} iterations, "
                     f"success {100 * kdl['success_rate']:.1f}%")
    a, b = cells.get(("jacobian_pinv", 10)), cells.get(("jacobian_pinv", 100))
    if a and b and finite(a["us_per_iteration"]) and finite(b["us_per_iteration"]):
        lines.append(f"pinv us/iteration growth 10→100 joints: x{b['us_per_iteration'] / a['us_per_iteration']:.1f} "
                     f"({a['us_per_iteration']:.3g} → {b['us_per_iteration']:.3g} µs; O(n) expected ~10)")
    else:
        lines.append("pinv us/iteration growth 10→100 joints: n/a (jacobian_pinv ran no iterations)")
    return lines


def cmd_table(directory):
    core = load(directory, "core.json")
    meta = core["meta"]
    recs = core["records"]
    print(f"IKChain solver-core benchmark  {meta['date']}  cpu: {meta['cpu']}  load avg {' '.join(meta['loadavg_at_start'].split()[:3])} → {' '.join(meta.get('loadavg_at_write', '?').split()[:3])}"
          f"{'  (QUICK RUN)' if meta.get('quick') else ''}")
    print(f"chain: {meta['chain']}; start: {meta['start']}; success: {meta['success']}")
    print("max_iterations: " + ", ".join(f"{k} {v}" for k, v in meta["max_iterations"].items()))
    print()
    print_grid("Success rate (%) by joints", recs, "success_rate", lambda v: f"{100 * v:.1f}")
    print_grid("Median time per solve (µs)", recs, "median_us", fmt_us)
    print_grid("Median iterations", recs, "median_iterations", lambda v: f"{v:g}" if finite(v) else "-")
    print_grid("Time per iteration (µs, all time / all iterations)", recs, "us_per_iteration", fmt_us)
    print_grid("Trials", recs, "trials", lambda v: f"{v}")
    base = core.get("baseline", [])
    if base:
        print("Building blocks (µs): one forward_kinematics pass / FK + dof axes + Jacobian (1 position goal)")
        print(f"  {'':<14}" + "".join(f"{b['joints']:>8}" for b in base))
        print(f"  {'fk':<14}" + "".join(f"{fmt_us(b['fk_us']):>8}" for b in base))
        print(f"  {'fk+jacobian':<14}" + "".join(f"{fmt_us(b['fk_jacobian_us']):>8}" for b in base))
        print()

    prec = load(directory, "precision.json")
    chains = sorted({r["chain"] for r in prec["records"]}, reverse=True)
    by = {(r["solver"], r["chain"]): r for r in prec["records"]}
    print("Precision: distance to a target 2 beyond full reach (optimal 2)")
    print("  setup: " + prec.get("setup", ""))
    print(f"  {'solver':<14}" + "".join(f"{c:>16}{'reason':>30}" for c in chains))
    for s in solvers_in(prec["records"]):
        row = f"  {s:<14}"
        for c in chains:
            r = by.get((s, c))
            row += f"{r['distance_to_goal']:>16.9f}{r['reason'][:28]:>30}" if r else " " * 46
        print(row)
    print("  lecture:       " + ", ".join(f"{n.split()[1]} {v}" for n, v in LECTURE) + ", optimal 2")
    print()
    for line in headline(core):
        print(line)


def robots_row_name(r):
    return r["solver"] + (" + restarts" if r["max_restarts"] else "") + (
        f" + {r['time_budget_us']:g} µs budget" if r.get("time_budget_us") else "")


def top_failures(r, count=2):
    failures = sorted(r.get("failures", {}).items(), key=lambda kv: -kv[1])[:count]
    return ", ".join(f"{k} {v}" for k, v in failures) or "-"


def cmd_robots_table(directory):
    """robots.json as Markdown tables: one per arm (rows: goal kind x solver x restarts)."""
    data = load(directory, "robots.json")
    meta = data["meta"]
    print(f"Real arms, limits on: {meta['goals_per_arm']} goals per arm, {meta['date']}, cpu: {meta['cpu']}, "
          f"load avg at start {' '.join(meta.get('loadavg_at_start', '?').split()[:3])}"
          f"{' (QUICK RUN)' if meta.get('quick') else ''}")
    print(f"Success: {meta['success']}. Times: CPU time of the solving thread (median / p90 / p99 µs); "
          f"wall p99 beside it. Restarts: up to {meta['restarts']}, mean used.")
    print()
    arms = [a["arm"] for a in data["arms"]]
    plain = [r for r in data["records"] if not r.get("skipped") and not r.get("time_budget_us")]
    for title, goal, restarts in (("Full pose, restarts allowed", "full_pose", True),
                                  ("Full pose, no restarts", "full_pose", False),
                                  ("Position only, no restarts", "position", False)):
        cells = [r for r in plain if r["goal"] == goal and bool(r["max_restarts"]) == restarts]
        print(f"{title}: success · median µs · p99 µs (CPU time)")
        print()
        print("| solver | " + " | ".join(arms) + " |")
        print("|---|" + "---|" * len(arms))
        for solver in solvers_in(cells):
            by_arm = {r["arm"]: r for r in cells if r["solver"] == solver}
            row = []
            for a in arms:
                r = by_arm.get(a)
                row.append(f"{100 * r['success_rate']:.2f} % · {fmt_us(r['cpu_median_us'])} · {fmt_us(r['cpu_p99_us'])}"
                           + (f" ({r['trials']} goals)" if r["trials"] != meta["goals_per_arm"] else "") if r else "-")
            print(f"| {solver} | " + " | ".join(row) + " |")
        print()
    for arm in data["arms"]:
        print(f"**{arm['arm']}** ({arm['joints']} joints, {arm['base']} → {arm['tip']}, L = {arm['length_m']:.3f} m; "
              f"our FK vs KDL's: {arm['fk_vs_kdl_position_m']:.1e} m, {arm['fk_vs_kdl_rotation_rad']:.1e} rad)")
        print()
        print("| goal | solver | goals | success | median µs | p90 µs | p99 µs | wall p99 µs | median it. | mean restarts | failures (reason) |")
        print("|---|---|--:|--:|--:|--:|--:|--:|--:|--:|---|")
        for r in data["records"]:
            if r["arm"] != arm["arm"]:
                continue
            if r.get("skipped"):
                print(f"| {r['goal']} | {robots_row_name(r)} | - | - | - | - | - | - | - | - | skipped: {r['note']} |")
                continue
            extra = (f"; worst CPU {r['worst_cpu_over_budget']:.2f}× budget (wall {r['worst_elapsed_over_budget']:.2f}×), "
                     f"over 1.10×: CPU {r['solves_over_1_10_budget_cpu']}, wall {r['solves_over_1_10_budget_wall']}"
                     if r.get("time_budget_us") else "")
            it = r["median_iterations"]
            print(f"| {r['goal']} | {robots_row_name(r)} | {r['trials']} | {100 * r['success_rate']:.2f} % | "
                  f"{fmt_us(r['cpu_median_us'])} | {fmt_us(r['cpu_p90_us'])} | {fmt_us(r['cpu_p99_us'])} | "
                  f"{fmt_us(r['p99_us'])} | {it:g} | {r['mean_restarts']:.2f} | {top_failures(r)}{extra} |"
                  if finite(it) else
                  f"| {r['goal']} | {robots_row_name(r)} | {r['trials']} | {100 * r['success_rate']:.2f} % | "
                  f"{fmt_us(r['cpu_median_us'])} | {fmt_us(r['cpu_p90_us'])} | {fmt_us(r['cpu_p99_us'])} | "
                  f"{fmt_us(r['p99_us'])} | - | {r['mean_restarts']:.2f} | {top_failures(r)}{extra} |")
        print()
    t = meta["targets"]
    print(f"Targets (on every arm): full pose with restarts ≥ {100 * t['full_pose_success']:g} % at median ≤ "
          f"{t['full_pose_median_us']} µs and p99 ≤ {t['full_pose_p99_us']} µs; position without restarts ≥ "
          f"{100 * t['position_success']:g} %; elapsed ≤ {t['worst_elapsed_over_budget']}× the budget (CPU time).")
    print()
    print("| solver | full-pose success | full-pose median | full-pose p99 | position success | budget |")
    print("|---|---|---|---|---|---|")
    word = {True: "met", False: "**missed**", None: "n/a"}
    for m in data["targets_met"]:
        print(f"| {m['solver']} | {word[m['full_pose_success']]} | {word[m['full_pose_median_us']]} | "
              f"{word[m['full_pose_p99_us']]} | {word[m['position_success']]} | {word[m['budget']]} |")


def fmt_num(v, digits=3):
    return f"{v:.{digits}g}" if finite(v) else "-"


def fmt_pct(v):
    return f"{100 * v:.2f} %" if finite(v) else "-"


def cmd_body_table(directory):
    """body.json as Markdown: the replay table, then the joint ranges against the recording."""
    data = load(directory, "body.json")
    meta = data["meta"]
    print(f"Body replay on CMU motion capture: {meta['date']}, cpu: {meta['cpu']}, "
          f"load avg at start {' '.join(meta.get('loadavg_at_start', '?').split()[:3])}, "
          f"frames per clip: {meta['frames_per_clip']}{' (QUICK RUN)' if meta.get('quick') else ''}"
          f"{'' if meta.get('tree_solvers') else '; no tree solver in this build (chain stack only)'}")
    print(f"Success: {meta['success']}. Times: {meta['times']}. Starts: {meta['starts']}.")
    print()
    print("| clip | solver | start | frames | success | median µs | p99 µs | MPJPE mm | position error mm "
          "p50 / p99 / max | rotation error ° p50 / p99 / max | foot slide mm | limit violations | median it. |")
    print("|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    for r in data["records"]:
        print(f"| {r['clip']} | {r['solver']} | {r['start']} | {r['frames']} | "
              f"{fmt_pct(r['success_rate'])} | {fmt_us(r['median_us'])} | {fmt_us(r['p99_us'])} | "
              f"{fmt_num(r['mpjpe_mm'])} | {fmt_num(r['position_error_p50_mm'], 2)} / "
              f"{fmt_num(r['position_error_p99_mm'], 2)} / {fmt_num(r['position_error_max_mm'], 3)} | "
              f"{fmt_num(r['rotation_error_p50_deg'], 2)} / {fmt_num(r['rotation_error_p99_deg'], 2)} / "
              f"{fmt_num(r['rotation_error_max_deg'], 3)} | {fmt_num(r['foot_slide_mm'], 2)} | "
              f"{r['limit_violations']} | {fmt_num(r['median_iterations'])} |"
              + (f" {r['note']}" if r.get("note") else ""))
    print()
    print("Joint ranges (swing cone about the bone's rest direction, twist about it; degrees) and the "
          "largest recorded swing / twist over every clip:")
    print()
    classes = {}
    for c in data["clips"]:
        for k in c["recorded_ranges"]["classes"]:
            e = classes.setdefault(k["class"], dict(k, joints=[]))
            if k["joints"] not in e["joints"]:  # per skeleton: CMU's LeftShoulder is a collar
                e["joints"].append(k["joints"])
            for f, pick in (("recorded_max_swing_deg", max), ("recorded_max_twist_deg", max),
                            ("recorded_min_twist_deg", min)):
                e[f] = pick(e[f], k[f])
    print("| class | joints | cone | twist | recorded swing max | recorded twist min / max |")
    print("|---|---|--:|--:|--:|--:|")
    for name, e in classes.items():
        print(f"| {name} | {' · '.join(e['joints'])} | {e['cone_deg']:g} | {e['twist_min_deg']:g} … "
              f"{e['twist_max_deg']:g} | {e['recorded_max_swing_deg']:.1f} | "
              f"{e['recorded_min_twist_deg']:.1f} / {e['recorded_max_twist_deg']:.1f} |")
    print()
    print("Recorded frames outside the ranges: " + ", ".join(
        f"{c['clip']} {c['recorded_ranges']['frames_outside_ranges']} of {c['frames']}" for c in data["clips"])
          + ". Skeletons: " + ", ".join(
        f"{c['clip']} {c['joints']} joints / {c['params']} params, {c['metres_per_unit']:.6g} m per unit, "
        f"rest stature {c['rest_stature_m']:.2f} m" for c in data["clips"]) + ".")


# ----------------------------------------------------------------------------------- PNG

# The lecture's three charts (convergence, time per iteration vs joints, iterations vs chain
# length), its precision table, and two more views of core.json (time per solve, success).
CHARTS = ["convergence.png", "ms_per_iteration.png", "iterations.png", "precision.png",
          "median_us.png", "success.png"]


def plot_robots(plt, directory, out_dir):
    """robots.png: per arm, success (full pose with restarts, position without) and median CPU µs."""
    from matplotlib import ticker
    data = load(directory, "robots.json")
    meta = data["meta"]
    arms = [a["arm"] for a in data["arms"]]
    rows = [r for r in data["records"] if not r.get("skipped") and not r.get("time_budget_us")]
    panels = [("full pose, restarts allowed (KDL: re-run from random starts)", "full_pose", True),
              ("position only, no restarts", "position", False)]
    fig, axes = plt.subplots(2, 2, figsize=(12, 8))
    for col, (title, goal, restarts) in enumerate(panels):
        cells = [r for r in rows if r["goal"] == goal and bool(r["max_restarts"]) == restarts]
        solvers = solvers_in(cells)
        width = 0.8 / max(1, len(solvers))
        for k, s in enumerate(solvers):
            by_arm = {r["arm"]: r for r in cells if r["solver"] == s}
            xs = [i + (k - (len(solvers) - 1) / 2) * width for i in range(len(arms))]
            axes[0][col].bar(xs, [100 * by_arm[a]["success_rate"] if a in by_arm else 0 for a in arms], width,
                             color=COLORS.get(s, "#000"), label=s)
            axes[1][col].bar(xs, [by_arm[a]["cpu_median_us"] if a in by_arm else 0 for a in arms], width,
                             color=COLORS.get(s, "#000"), label=s)
        for row, label in ((0, "success (%)"), (1, "median µs (CPU time)")):
            ax = axes[row][col]
            ax.set_xticks(range(len(arms)), arms)
            ax.set_ylabel(label)
        axes[0][col].set_title(title, fontsize=10)
        axes[0][col].axhline(99.9, color="#d62728", linestyle="--", linewidth=1)
        axes[0][col].set_ylim(0, 105)
        axes[1][col].set_yscale("log")
        axes[1][col].yaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        axes[1][col].yaxis.set_minor_formatter(ticker.NullFormatter())
        if goal == "full_pose":
            axes[1][col].axhline(30, color="#d62728", linestyle="--", linewidth=1)
        axes[0][col].legend(fontsize=7, ncol=2, loc="lower left")
    fig.suptitle("Real arms, limits on: every solver and KDL on the same goals (dashed: the targets)")
    fig.text(0.99, 0.01, f"{meta['goals_per_arm']} goals per arm; scripts/bench {meta['date']}"
             f"{' (QUICK RUN)' if meta.get('quick') else ''}", ha="right", va="bottom", fontsize=7, color="#666666")
    fig.tight_layout(rect=(0, 0.03, 1, 0.96))
    path = os.path.join(out_dir, "robots.png")
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    print(f"wrote {path}")


def plot_body(plt, directory, out_dir):
    """body.png: per clip and solver x start, success, median/p99 CPU µs and MPJPE."""
    from matplotlib import ticker
    data = load(directory, "body.json")
    meta = data["meta"]
    recs = data["records"]
    clips = [c["clip"] for c in data["clips"]]
    series = []
    for r in recs:
        key = (r["solver"], r["start"])
        if key not in series:
            series.append(key)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.8))
    width = 0.8 / max(1, len(series))
    for k, (solver, start) in enumerate(series):
        by_clip = {r["clip"]: r for r in recs if r["solver"] == solver and r["start"] == start}
        xs = [i + (k - (len(series) - 1) / 2) * width for i in range(len(clips))]
        color = COLORS.get(solver, "#555555" if solver.startswith("chain_stack") else "#000000")
        style = dict(color=color, alpha=1.0 if start == "warm" else 0.45, edgecolor="#333333", linewidth=0.5,
                     label=f"{solver} {start}")
        get = lambda c, f: by_clip[c][f] if c in by_clip and finite(by_clip[c][f]) else 0
        axes[0].bar(xs, [100 * get(c, "success_rate") for c in clips], width, **style)
        med = [get(c, "median_us") for c in clips]
        p99 = [get(c, "p99_us") for c in clips]
        axes[1].bar(xs, med, width, **style)
        axes[1].errorbar(xs, med, yerr=[[0] * len(med), [max(0, b - a) for a, b in zip(med, p99)]], fmt="none",
                         ecolor="#333333", elinewidth=0.8, capsize=2)
        axes[2].bar(xs, [get(c, "mpjpe_mm") for c in clips], width, **style)
    for ax, label in zip(axes, ("frames with every effector within 1 mm and 1° (%)",
                                "CPU µs per frame (bar: median, whisker: p99)", "MPJPE (mm)")):
        ax.set_xticks(range(len(clips)), clips)
        ax.set_ylabel(label, fontsize=9)
    axes[0].set_ylim(0, 105)
    axes[0].axhline(99.9, color="#d62728", linestyle="--", linewidth=1)
    axes[1].set_yscale("log")
    axes[1].yaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
    axes[1].axhline(25, color="#d62728", linestyle="--", linewidth=1)
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle("Whole body on CMU motion capture: hips, hands, feet and head replayed as goals "
                 "(dashed: issue 14's warm targets)", fontsize=10)
    fig.text(0.99, 0.01, f"scripts/bench --body {meta['date']}{' (QUICK RUN)' if meta.get('quick') else ''}",
             ha="right", va="bottom", fontsize=7, color="#666666")
    fig.tight_layout(rect=(0, 0.03, 1, 0.95))
    path = os.path.join(out_dir, "body.png")
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    print(f"wrote {path}")


def cmd_plots(directory, out_dir):
    import matplotlib
    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt

    os.makedirs(out_dir, exist_ok=True)
    if os.path.exists(os.path.join(directory, "robots.json")):
        plot_robots(plt, directory, out_dir)
    if os.path.exists(os.path.join(directory, "body.json")):
        plot_body(plt, directory, out_dir)
    if not os.path.exists(os.path.join(directory, "core.json")):
        return
    core = load(directory, "core.json")
    conv = load(directory, "convergence.json")
    prec = load(directory, "precision.json")
    recs = core["records"]
    meta = core["meta"]
    stamp = f"scripts/bench {meta['date']}{' (QUICK RUN)' if meta.get('quick') else ''}"
    os.makedirs(out_dir, exist_ok=True)
    plt.rcParams.update({"figure.figsize": (8, 5), "figure.dpi": 100, "axes.grid": True,
                         "grid.alpha": 0.35, "font.size": 10})

    def style(s):
        return {"color": COLORS.get(s, "#000000"), "linestyle": "--" if s == "kdl_lma" else "-",
                "linewidth": 1.8, "label": s}

    def save(fig, name, subtitle):
        fig.text(0.99, 0.01, f"{subtitle}; {stamp}", ha="right", va="bottom", fontsize=7, color="#666666")
        fig.tight_layout(rect=(0, 0.03, 1, 1))
        path = os.path.join(out_dir, name)
        fig.savefig(path, metadata={"Software": None})  # no matplotlib version stamp: stable bytes
        plt.close(fig)
        print(f"wrote {path}")

    # 1. Convergence: error vs iteration, one line per solver.
    fig, ax = plt.subplots()
    for t in conv["traces"]:
        ks = [k for k, e in enumerate(t["errors"]) if finite(e) and e > 0]
        ax.plot(ks, [t["errors"][k] for k in ks], marker="o", markersize=3, **style(t["solver"]))
    if conv["traces"]:
        ax.axhline(conv["traces"][0]["tolerance"], color="#999999", linestyle=":", label="tolerance 1e-5·L")
    ax.set_yscale("log")
    longest = max((len(t["errors"]) for t in conv["traces"]), default=1)
    if longest > 60:  # long linear tails (CCD/FABRIK near full extension): log the budget axis
        ax.set_xscale("symlog", linthresh=10)
    else:
        ax.xaxis.get_major_locator().set_params(integer=True)
    ax.set_xlabel("iteration budget k (the solver re-run from the rest pose with max_iterations = k)")
    ax.set_ylabel("tip distance after k iterations")
    ax.set_title("Convergence: error vs iteration (10 joints)")
    ax.legend(fontsize=8)
    save(fig, "convergence.png", "one fixed reachable target, every run from the rest pose")

    def per_joint(name, title, field, ylabel, scale=1.0, ylog=True, with_fk=False):
        fig, ax = plt.subplots()
        for s in solvers_in(recs):
            rows = sorted((r for r in recs if r["solver"] == s and finite(r[field])), key=lambda r: r["joints"])
            if rows:
                ax.plot([r["joints"] for r in rows], [r[field] * scale for r in rows], marker="o",
                        markersize=3, **style(s))
        if with_fk and core.get("baseline"):  # yardstick: one forward-kinematics pass
            base = core["baseline"]
            ax.plot([b["joints"] for b in base], [b["fk_us"] * scale for b in base], color="#aaaaaa",
                    linestyle=":", label="one FK pass")
        ax.set_xscale("log")
        joints = sorted({r["joints"] for r in recs})
        ax.set_xticks(joints, [str(n) for n in joints])
        ax.minorticks_off()
        if ylog:
            ax.set_yscale("log")
        ax.set_xlabel("joints")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.legend(fontsize=8)
        save(fig, name, "hinge chain, random reachable targets, rest-pose start")

    per_joint("ms_per_iteration.png", "Time per iteration vs number of joints", "us_per_iteration",
              "ms per iteration (all time / all iterations)", scale=1e-3, with_fk=True)
    per_joint("iterations.png", "Iterations vs chain length", "median_iterations", "median iterations")
    per_joint("median_us.png", "Time per solve vs chain length", "median_us", "median µs per solve")
    per_joint("success.png", "Success rate vs chain length", "success_rate",
              "fraction of targets reached within 1e-5·L", ylog=False)

    # 4. Precision: distance to a goal 2 beyond reach, ours next to the lecture's table.
    chains = sorted({r["chain"] for r in prec["records"]}, reverse=True)
    groups = []
    for chain in chains:
        rows = {r["solver"]: r for r in prec["records"] if r["chain"] == chain}
        groups.append((f"ours, {chain}", [(s, rows[s]["distance_to_goal"], COLORS.get(s, "#000"), "")
                                          for s in solvers_in(list(rows.values()))]))
    lecture = prec.get("lecture") or {}
    names = {"jacobian_inverse": "JI", "ccd": "CCD", "bfgs": "BFGS"}
    groups.append(("lecture", [(names[k], lecture[k], "#bbbbbb", "//") for k in names if k in lecture]
                   or [(n.split()[1], v, "#bbbbbb", "//") for n, v in LECTURE]))
    fig, ax = plt.subplots(figsize=(10, 5))
    x = 0.0
    centers = []
    for label, bars in groups:
        first = x
        for name, value, color, hatch in bars:
            ax.bar(x, value, width=0.8, color=color, hatch=hatch, edgecolor="#333333", linewidth=0.5)
            ax.text(x, value + 0.05, f"{value:.6f}" if label != "lecture" else f"{value:.2f}",
                    ha="center", va="bottom", rotation=90, fontsize=7)
            ax.text(x, -0.08, name, ha="center", va="top", rotation=90, fontsize=7)
            x += 1.0
        centers.append(((first + x - 1.0) / 2, label))
        x += 1.0
    optimal = float(lecture.get("optimal", 2.0))
    ax.axhline(optimal, color="#d62728", linestyle="--", linewidth=1, label=f"optimal {optimal:g}")
    ax.set_xticks([c for c, _ in centers], [l for _, l in centers])
    ax.tick_params(axis="x", pad=60)
    ax.set_ylim(0, max(v for _, bars in groups for _, v, _, _ in bars) * 1.3)
    ax.set_ylabel("distance from the tip to the goal")
    ax.set_title("Precision: a goal 2 beyond full reach (10 joints; optimal 2)")
    ax.legend(loc="upper left", fontsize=8)
    save(fig, "precision.png", "each solver from a bent warm start, its usual budget")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["table", "robots-table", "body-table", "plots"])
    ap.add_argument("directory", help="where core.json, precision.json and convergence.json are")
    ap.add_argument("--out", help="where to write the PNG files (plots; default: DIRECTORY)")
    args = ap.parse_args()
    if args.command == "table":
        cmd_table(args.directory)
    elif args.command == "robots-table":
        cmd_robots_table(args.directory)
    elif args.command == "body-table":
        cmd_body_table(args.directory)
    else:
        cmd_plots(args.directory, args.out or args.directory)
    return 0


if __name__ == "__main__":
    sys.exit(main())
