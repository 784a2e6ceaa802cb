// The lecture's figures, computed in the page by the wasm core and drawn with uPlot. The work is
// cut into small tasks run between frames, so the 3-D view stays live while the charts fill.
import uPlot from 'uplot';
import 'uplot/dist/uPlot.min.css';

import type { IKCore } from './ikchain.js';
import { SOLVERS, SolverKind } from './ikchain.js';
import { measureCell } from './measure.js';
import type { Cell } from './measure.js';

export const CHART_SOLVERS = [SolverKind.CCD, SolverKind.FABRIK, SolverKind.JacobianPinv, SolverKind.DLS, SolverKind.BFGS];
export const JOINT_COUNTS = [2, 3, 5, 7, 10, 15, 20, 30, 50, 70, 100];
export const SPEED_SOLVERS = [SolverKind.DLS, SolverKind.BFGS, SolverKind.JacobianPinv];
const COLORS: Record<number, string> = {
  [SolverKind.CCD]: '#f28e2b', [SolverKind.FABRIK]: '#e15759', [SolverKind.JacobianPinv]: '#76b7b2',
  [SolverKind.DLS]: '#4e79a7', [SolverKind.BFGS]: '#59a14f',
};
const LECTURE: Record<number, number | undefined> = {
  [SolverKind.JacobianPinv]: 5.85, [SolverKind.CCD]: 3.37, [SolverKind.BFGS]: 2.53,
};
const label = (k: SolverKind) => SOLVERS.find((s) => s.kind === k)!.label;

export interface ChartState {
  complete: boolean;
  convergence: { solver: string; errors: number[]; stopped: string }[];
  cells: Cell[];
  precision: { solver: string; planar: number; spatial: number; lecture: number | null }[];
  speed: { solver: string; usPerSolve: number; medianIterations: number; trials: number }[];
  plots: Record<string, uPlot>;
}

// Log-scale tick labels: uPlot's default prints 1e-4 as "0".
const logTicks = (_u: uPlot, values: number[]) => values.map((v) => (v == null ? "" : v >= 0.01 && v < 1e4 ? String(+v.toPrecision(3)) : v.toExponential(0)));

function plot(el: HTMLElement, title: string, xLabel: string, yLabel: string, log: boolean, logX: boolean,
              xs: number[], series: { name: string; color: string; ys: (number | null)[] }[]): uPlot {
  const opts: uPlot.Options = {
    title, width: Math.max(320, el.clientWidth || 480), height: 260,
    scales: { x: logX ? { time: false, distr: 3 } : { time: false }, y: log ? { distr: 3 } : {} },
    axes: [
      { label: xLabel, stroke: '#b7bfcc', grid: { stroke: '#2a2e37' }, ...(logX ? { values: logTicks } : {}) },
      { label: yLabel, stroke: '#b7bfcc', grid: { stroke: '#2a2e37' }, size: 70, ...(log ? { values: logTicks } : {}) },
    ],
    series: [{ label: xLabel }, ...series.map((s) => ({ label: s.name, stroke: s.color, width: 2, points: { show: xs.length < 20 } }))],
  };
  const data = [xs, ...series.map((s) => s.ys)] as uPlot.AlignedData;
  return new uPlot(opts, data, el);
}

const nextTask = () => new Promise<void>((r) => setTimeout(r, 0));

export async function computeCharts(core: IKCore, state: ChartState, status: (s: string) => void): Promise<void> {
  // 1. Convergence: error after a budget of k iterations, 10 joints, the bench's target.
  for (const k of CHART_SOLVERS) {
    const t = core.convergenceTrace(k);
    state.convergence.push({ solver: SOLVERS.find((s) => s.kind === k)!.id, errors: t.errors, stopped: t.stopped });
    await nextTask();
  }
  const maxLen = Math.max(...state.convergence.map((c) => c.errors.length));
  const ks = Array.from({ length: maxLen }, (_, i) => i);
  state.plots.convergence = plot(document.getElementById('chart-convergence')!, '', 'iteration budget k',
    'distance to target (m)', true, false, ks, CHART_SOLVERS.map((k, i) => ({
      name: label(k), color: COLORS[k],
      ys: ks.map((x) => { const e = state.convergence[i].errors[x]; return e === undefined ? null : Math.max(e, 1e-12); }),
    })));

  // 2. Precision: the lecture's out-of-reach goal.
  const tbody = document.querySelector('#precision tbody')!;
  for (const k of CHART_SOLVERS) {
    const planar = core.precisionRun(k, true);
    const spatial = core.precisionRun(k, false);
    state.precision.push({ solver: SOLVERS.find((s) => s.kind === k)!.id, planar: planar.distance, spatial: spatial.distance, lecture: LECTURE[k] ?? null });
    const tr = document.createElement('tr');
    tr.innerHTML = `<td>${label(k)}</td><td>${planar.distance.toFixed(6)}</td><td>${spatial.distance.toFixed(6)}</td><td>${LECTURE[k]?.toFixed(2) ?? '–'}</td>`;
    tbody.appendChild(tr);
  }
  const opt = document.createElement('tr');
  opt.className = 'optimal';
  opt.innerHTML = '<td>optimal</td><td>2</td><td>2</td><td>2</td>';
  tbody.appendChild(opt);
  await nextTask();

  // 3. Cost per iteration and iterations vs chain length.
  for (const n of JOINT_COUNTS) {
    status(`measuring ${n}-joint chains…`);
    for (const k of CHART_SOLVERS) {
      const trials = n <= 10 ? 40 : n <= 30 ? 20 : 8;
      state.cells.push(measureCell(core, k, n, trials, 3));
      await nextTask();
    }
  }
  const cell = (k: SolverKind, n: number) => state.cells.find((c) => c.solver === k && c.joints === n);
  state.plots.perIteration = plot(document.getElementById('chart-per-iteration')!, '', 'joints', 'µs per iteration', true, true,
    JOINT_COUNTS, CHART_SOLVERS.map((k) => ({ name: label(k), color: COLORS[k], ys: JOINT_COUNTS.map((n) => cell(k, n)?.usPerIteration ?? null) })));
  state.plots.iterations = plot(document.getElementById('chart-iterations')!, '', 'joints', 'median iterations', true, true,
    JOINT_COUNTS, CHART_SOLVERS.map((k) => ({ name: label(k), color: COLORS[k], ys: JOINT_COUNTS.map((n) => cell(k, n)?.medianIterations ?? null) })));

  // 4. Speed at 10 joints: the figure compared with the native benchmark (docs/web-demo.md).
  status('timing the 10-joint chain…');
  const speedBody = document.querySelector('#speed tbody')!;
  for (const k of SPEED_SOLVERS) {
    await nextTask();
    const c = measureCell(core, k, 10, 1000, 3, 25);
    state.speed.push({ solver: SOLVERS.find((s) => s.kind === k)!.id, usPerSolve: c.usPerSolve, medianIterations: c.medianIterations, trials: c.trials });
    const tr = document.createElement('tr');
    tr.innerHTML = `<td>${label(k)}</td><td>${c.usPerSolve.toFixed(2)}</td><td>${c.medianIterations}</td>`;
    speedBody.appendChild(tr);
  }
  state.complete = true;
  status('done');
}
