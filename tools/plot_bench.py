#!/usr/bin/env python3
"""Tables and SVG charts from the solver-core benchmark's JSON (build/bench/*.json).

No timing happens here: everything comes from the JSON written by bench/core_bench.cpp.
Python standard library only (the SVG is written by hand; no matplotlib).

  tools/plot_bench.py table DIR              print the tables and the headline checks
  tools/plot_bench.py plots DIR [--copy-to D] write DIR/*.svg (and copy them into D)
"""
import argparse
import json
import math
import os
import shutil
import sys
import xml.etree.ElementTree as ET
from xml.sax.saxutils import escape

COLORS = {
    "two_bone": "#8c564b",
    "ccd": "#1f77b4",
    "fabrik": "#ff7f0e",
    "jacobian_pinv": "#2ca02c",
    "dls": "#d62728",
    "bfgs": "#9467bd",
    "kdl_lma": "#555555",
}
ORDER = ["two_bone", "ccd", "fabrik", "jacobian_pinv", "dls", "bfgs", "kdl_lma"]
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


# ----------------------------------------------------------------------------------- SVG

def nice_linear_ticks(lo, hi, count=6):
    if hi <= lo:
        hi = lo + 1.0
    raw = (hi - lo) / count
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    start = math.floor(lo / step) * step
    ticks = []
    t = start
    while t <= hi + 1e-9 * step:
        ticks.append(round(t, 12))
        t += step
    if ticks[-1] < hi - 1e-9 * step:  # the last tick covers the data
        ticks.append(round(t, 12))
    return ticks


def log_ticks(lo, hi):
    a, b = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    if b - a <= 2:  # a narrow range: 1-2-5 steps
        return [m * 10 ** e for e in range(a, b + 1) for m in (1, 2, 5) if lo <= m * 10 ** e * 1.0001
                and m * 10 ** e <= hi * 1.0001]
    step = max(1, (b - a) // 8)
    return [10.0 ** e for e in range(a, b + 1, step)]


def tick_label(v, log):
    if log:
        e = math.log10(v)
        if abs(e - round(e)) < 1e-9 and (e < -2 or e > 4):
            return f"1e{int(round(e))}"
    if v == 0:
        return "0"
    if abs(v) >= 1e4 or abs(v) < 1e-3:
        return f"{v:.0e}"
    return f"{v:g}"


class Plot:
    """A line chart with linear or log axes, written as SVG text."""

    W, H = 760, 460
    L, R, T, B = 80, 190, 50, 60  # margins; the legend lives in the right margin

    def __init__(self, title, xlabel, ylabel, xlog=False, ylog=False, subtitle=""):
        self.title, self.subtitle, self.xlabel, self.ylabel = title, subtitle, xlabel, ylabel
        self.xlog, self.ylog = xlog, ylog
        self.series = []  # (label, color, points, dashed)
        self.hlines = []  # (y, label, color)

    def line(self, label, xs, ys, color, dashed=False):
        pts = [(x, y) for x, y in zip(xs, ys) if finite(x) and finite(y)
               and (not self.xlog or x > 0) and (not self.ylog or y > 0)]
        if pts:
            self.series.append((label, color, pts, dashed))

    def hline(self, y, label, color="#999999"):
        self.hlines.append((y, label, color))

    def _range(self, values, log):
        lo, hi = min(values), max(values)
        if log:
            lo, hi = 10 ** math.floor(math.log10(lo) + 1e-9), 10 ** math.ceil(math.log10(hi) - 1e-9)
            if hi <= lo:
                hi = lo * 10
            return lo, hi, log_ticks(lo, hi)
        ticks = nice_linear_ticks(min(lo, 0.0) if lo > 0 and lo < 0.3 * hi else lo, hi)
        return ticks[0], ticks[-1], ticks

    def render(self):
        pw, ph = self.W - self.L - self.R, self.H - self.T - self.B
        xs = [x for _, _, pts, _ in self.series for x, _ in pts]
        ys = [y for _, _, pts, _ in self.series for _, y in pts] + [y for y, _, _ in self.hlines]
        out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{self.W}" height="{self.H}" '
               f'viewBox="0 0 {self.W} {self.H}" font-family="sans-serif" font-size="12">',
               f'<rect width="{self.W}" height="{self.H}" fill="white"/>',
               f'<text x="{self.W / 2}" y="22" text-anchor="middle" font-size="16" font-weight="bold">'
               f'{escape(self.title)}</text>']
        if self.subtitle:
            out.append(f'<text x="{self.W / 2}" y="39" text-anchor="middle" fill="#555">{escape(self.subtitle)}</text>')
        if not xs:
            out.append(f'<text x="{self.W / 2}" y="{self.H / 2}" text-anchor="middle" fill="#a00">'
                       'no data (no solver produced a plottable value)</text></svg>')
            return "\n".join(out)
        x0, x1, xt = self._range(xs, self.xlog)
        y0, y1, yt = self._range(ys, self.ylog)

        def sx(x):
            f = (math.log10(x) - math.log10(x0)) / (math.log10(x1) - math.log10(x0)) if self.xlog \
                else (x - x0) / ((x1 - x0) or 1)
            return self.L + f * pw

        def sy(y):
            f = (math.log10(y) - math.log10(y0)) / (math.log10(y1) - math.log10(y0)) if self.ylog \
                else (y - y0) / ((y1 - y0) or 1)
            return self.T + ph - f * ph

        for t in xt:
            X = sx(t)
            out.append(f'<line x1="{X:.1f}" y1="{self.T}" x2="{X:.1f}" y2="{self.T + ph}" stroke="#e4e4e4"/>')
            out.append(f'<text x="{X:.1f}" y="{self.T + ph + 16}" text-anchor="middle">{tick_label(t, self.xlog)}</text>')
        for t in yt:
            Y = sy(t)
            out.append(f'<line x1="{self.L}" y1="{Y:.1f}" x2="{self.L + pw}" y2="{Y:.1f}" stroke="#e4e4e4"/>')
            out.append(f'<text x="{self.L - 6}" y="{Y + 4:.1f}" text-anchor="end">{tick_label(t, self.ylog)}</text>')
        out.append(f'<rect x="{self.L}" y="{self.T}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>')
        out.append(f'<text x="{self.L + pw / 2}" y="{self.H - 18}" text-anchor="middle">{escape(self.xlabel)}</text>')
        out.append(f'<text transform="translate(20 {self.T + ph / 2}) rotate(-90)" text-anchor="middle">'
                   f'{escape(self.ylabel)}</text>')
        for y, label, color in self.hlines:
            Y = sy(y)
            out.append(f'<line x1="{self.L}" y1="{Y:.1f}" x2="{self.L + pw}" y2="{Y:.1f}" stroke="{color}" '
                       f'stroke-dasharray="6 4"/>')
            out.append(f'<text x="{self.L + pw - 4}" y="{Y - 4:.1f}" text-anchor="end" fill="{color}">'
                       f'{escape(label)}</text>')
        for label, color, pts, dashed in self.series:
            path = " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in pts)
            dash = ' stroke-dasharray="7 4"' if dashed else ""
            out.append(f'<polyline points="{path}" fill="none" stroke="{color}" stroke-width="2"{dash}/>')
            if len(pts) <= 40:
                for x, y in pts:
                    out.append(f'<circle cx="{sx(x):.1f}" cy="{sy(y):.1f}" r="3" fill="{color}"/>')
        ly = self.T + 10
        for label, color, _, dashed in self.series:
            dash = ' stroke-dasharray="7 4"' if dashed else ""
            lx = self.L + pw + 15
            out.append(f'<line x1="{lx}" y1="{ly}" x2="{lx + 24}" y2="{ly}" stroke="{color}" stroke-width="2"{dash}/>')
            out.append(f'<text x="{lx + 30}" y="{ly + 4}">{escape(label)}</text>')
            ly += 20
        out.append("</svg>")
        return "\n".join(out)


def bar_chart(title, subtitle, groups, optimal, ylabel):
    """groups: [(group_label, [(bar_label, value, color, hatched)])]; a dashed line at `optimal`."""
    W, H, L, R, T, B = 760, 470, 70, 70, 62, 110
    pw, ph = W - L - R, H - T - B
    values = [v for _, bars in groups for _, v, _, _ in bars if finite(v)] + [optimal]
    # A runaway value (a solver that barely moved) would squash the interesting ones: cap the axis
    # at 4x the optimum (well above the lecture's worst, 5.85) and label clipped bars.
    ticks = nice_linear_ticks(0.0, min(max(values), 4.0 * optimal) * 1.08)
    y1 = ticks[-1]

    def sy(y):
        return T + ph - y / y1 * ph

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" '
           f'font-family="sans-serif" font-size="12">',
           '<defs><pattern id="hatch" width="6" height="6" patternUnits="userSpaceOnUse" '
           'patternTransform="rotate(45)"><rect width="6" height="6" fill="#f2f2f2"/>'
           '<line x1="0" y1="0" x2="0" y2="6" stroke="#999" stroke-width="2"/></pattern></defs>',
           f'<rect width="{W}" height="{H}" fill="white"/>',
           f'<text x="{W / 2}" y="22" text-anchor="middle" font-size="16" font-weight="bold">{escape(title)}</text>',
           f'<text x="{W / 2}" y="39" text-anchor="middle" fill="#555">{escape(subtitle)}</text>']
    for t in ticks:
        out.append(f'<line x1="{L}" y1="{sy(t):.1f}" x2="{L + pw}" y2="{sy(t):.1f}" stroke="#e4e4e4"/>')
        out.append(f'<text x="{L - 6}" y="{sy(t) + 4:.1f}" text-anchor="end">{tick_label(t, False)}</text>')
    out.append(f'<text transform="translate(20 {T + ph / 2}) rotate(-90)" text-anchor="middle">{escape(ylabel)}</text>')
    nbars = sum(len(b) for _, b in groups) + (len(groups) - 1)
    slot = pw / max(nbars, 1)
    i = 0
    for gi, (glabel, bars) in enumerate(groups):
        g0 = i
        for label, v, color, hatched in bars:
            x = L + i * slot + slot * 0.12
            w = slot * 0.76
            if finite(v):
                h = min(v, y1) / y1 * ph
                fill = "url(#hatch)" if hatched else color
                stroke = color if hatched else "none"
                out.append(f'<rect x="{x:.1f}" y="{T + ph - h:.1f}" width="{w:.1f}" height="{h:.1f}" fill="{fill}" '
                           f'stroke="{stroke}"/>')
                txt = f"{v:.4f}" if v <= y1 else f"{v:.3g}↑"
                out.append(f'<text x="{x + w / 2:.1f}" y="{T + ph - h - 4:.1f}" text-anchor="middle" '
                           f'font-size="10">{txt}</text>')
            else:
                out.append(f'<text x="{x + w / 2:.1f}" y="{T + ph - 4:.1f}" text-anchor="middle" '
                           f'font-size="10">n/a</text>')
            out.append(f'<text transform="translate({x + w / 2 + 4:.1f} {T + ph + 8}) rotate(-50)" '
                       f'text-anchor="end" font-size="11">{escape(label)}</text>')
            i += 1
        gx = L + (g0 + i) / 2 * slot
        out.append(f'<text x="{gx:.1f}" y="{H - 8}" text-anchor="middle" font-weight="bold">{escape(glabel)}</text>')
        i += 1
    out.append(f'<line x1="{L}" y1="{sy(optimal):.1f}" x2="{L + pw}" y2="{sy(optimal):.1f}" stroke="#000" '
               f'stroke-dasharray="6 4"/>')
    out.append(f'<text x="{L + pw + 4}" y="{sy(optimal) + 4:.1f}">optimal {optimal:g}</text>')
    out.append(f'<rect x="{L}" y="{T}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>')
    out.append("</svg>")
    return "\n".join(out)


def cmd_plots(directory, copy_to):
    core = load(directory, "core.json")
    conv = load(directory, "convergence.json")
    prec = load(directory, "precision.json")
    recs = core["records"]
    when = core["meta"]["date"][:10]
    charts = {}

    p = Plot("Convergence: error vs iteration (10 joints)", "iteration budget k", "tip distance after k iterations",
             ylog=True, subtitle=f"one fixed reachable target, from the rest pose; scripts/bench {when}")
    for t in conv["traces"]:
        errs = [max(e, 1e-16) if finite(e) else None for e in t["errors"]]
        p.line(t["solver"], list(range(len(errs))), errs, COLORS.get(t["solver"], "#000"),
               dashed=t["solver"] == "kdl_lma")
    if conv["traces"]:
        p.hline(conv["traces"][0]["tolerance"], "tolerance 1e-5·L")
    charts["convergence.svg"] = p.render()

    def per_joint_chart(name, title, field, ylabel, ylog=True, with_fk=False):
        p = Plot(title, "joints (log)", ylabel, xlog=True, ylog=ylog,
                 subtitle=f"hinge chain, random reachable targets, rest-pose start; scripts/bench {when}")
        for s in solvers_in(recs):
            rows = sorted((r for r in recs if r["solver"] == s), key=lambda r: r["joints"])
            p.line(s, [r["joints"] for r in rows], [r[field] for r in rows], COLORS.get(s, "#000"),
                   dashed=s == "kdl_lma")
        if with_fk and core.get("baseline"):  # yardstick: one forward-kinematics pass
            base = core["baseline"]
            p.line("one FK pass", [b["joints"] for b in base], [b["fk_us"] for b in base], "#aaaaaa", dashed=True)
        charts[name] = p.render()

    per_joint_chart("us_per_iteration.svg", "Time per iteration vs chain length", "us_per_iteration",
                    "µs per iteration (log)", with_fk=True)
    per_joint_chart("iterations.svg", "Iterations vs chain length", "median_iterations", "median iterations (log)")
    per_joint_chart("median_us.svg", "Time per solve vs chain length", "median_us", "median µs per solve (log)")
    per_joint_chart("success.svg", "Success rate vs chain length", "success_rate",
                    "fraction within 1e-5·L", ylog=False)

    groups = []
    for chain in sorted({r["chain"] for r in prec["records"]}, reverse=True):
        rows = {r["solver"]: r for r in prec["records"] if r["chain"] == chain}
        bars = [(s, rows[s]["distance_to_goal"], COLORS.get(s, "#000"), False) for s in solvers_in(list(rows.values()))]
        groups.append((chain, bars))
    groups.append(("lecture", [(n, v, "#777777", True) for n, v in LECTURE]))
    charts["precision.svg"] = bar_chart(
        "Precision: target 2 beyond full reach", f"distance to goal, 10 joints (optimal 2); scripts/bench {when}",
        groups, 2.0, "distance to goal")

    for name, text in charts.items():
        path = os.path.join(directory, name)
        with open(path, "w", encoding="utf-8") as f:
            f.write('<?xml version="1.0" encoding="UTF-8"?>\n' + text + "\n")
        ET.parse(path)  # well-formed XML, or raise
        print(f"wrote {path}")
        if copy_to:
            os.makedirs(copy_to, exist_ok=True)
            shutil.copy(path, os.path.join(copy_to, name))
            print(f"copied to {os.path.join(copy_to, name)}")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["table", "plots"])
    ap.add_argument("directory", help="where core.json, precision.json and convergence.json are")
    ap.add_argument("--copy-to", help="also copy the SVG files here (plots only)")
    args = ap.parse_args()
    if args.command == "table":
        cmd_table(args.directory)
    else:
        cmd_plots(args.directory, args.copy_to)
    return 0


if __name__ == "__main__":
    sys.exit(main())
