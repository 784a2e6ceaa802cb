// The body view's live charts (uPlot): per frame, the solve's µs and iterations, and each goal's
// error. Redrawn from BodyView.history a few times a second.
import uPlot from 'uplot';

import type { BodyView } from './bodyView.js';
import { LEVEL_COLOR } from './bodyView.js';
import { BODY_GOALS } from './humanoid.js';

const GOAL_COLORS = ['#6fd38c', '#3f9e5c', '#b5e8c4', '#2f7a48', '#d3f36f', '#f7a24f', '#e2725b', '#f7d44f', '#8ab4f8'];
const FLOOR_MM = 1e-5; // errors below this (mm, or degrees) are drawn on it: the log scale has no 0

// Log-scale tick labels: uPlot's default prints 1e-4 as "0".
const logTicks = (_u: uPlot, values: number[]) =>
  values.map((v) => (v == null ? '' : v >= 0.01 && v < 1e4 ? String(+v.toPrecision(3)) : v.toExponential(0)));

const axis = (label: string, extra: Partial<uPlot.Axis> = {}): uPlot.Axis =>
  ({ label, stroke: '#b7bfcc', grid: { stroke: '#2a2e37' }, ...extra });

export class BodyCharts {
  readonly time: uPlot;
  readonly error: uPlot;

  constructor(timeEl: HTMLElement, errorEl: HTMLElement) {
    const width = (el: HTMLElement) => Math.max(320, el.clientWidth || 480);
    this.time = new uPlot({
      width: width(timeEl), height: 200, legend: { live: false },
      scales: { x: { time: false, range: (_u, min, max) => [min, Math.max(max, min + 1)] }, us: { range: (_u, _min, max) => [0, Math.max(10, max * 1.1)] }, it: { range: (_u, _min, max) => [0, Math.max(5, max * 1.1)] } },
      axes: [axis('time (s)'), axis('µs', { scale: 'us', size: 60 }), axis('iterations', { scale: 'it', side: 1, grid: { show: false } })],
      series: [{ label: 't' }, { label: 'µs', scale: 'us', stroke: '#4e79a7', width: 1.5 }, { label: 'iterations', scale: 'it', stroke: '#f28e2b', width: 1.5 }],
    }, [[], [], []], timeEl);
    this.error = new uPlot({
      width: width(errorEl), height: 200, legend: { live: false },
      scales: { x: { time: false, range: (_u, min, max) => [min, Math.max(max, min + 1)] }, y: { distr: 3 } },
      axes: [axis('time (s)'), axis('mm · °', { size: 70, values: logTicks })],
      series: [{ label: 't' }, ...BODY_GOALS.map((g, i) => ({
        label: `${g.label} (${g.level})`, stroke: GOAL_COLORS[i] ?? `#${LEVEL_COLOR[g.level as 1 | 2 | 3].toString(16)}`, width: 1.5,
        dash: g.level === 3 ? [4, 4] : undefined,
      }))],
    }, [[], ...BODY_GOALS.map(() => [])], errorEl);
  }

  update(view: BodyView): void {
    const h = view.history;
    this.time.setData([h.t, h.us, h.iterations]);
    this.error.setData([h.t, ...h.errors.map((series, i) => {
      const scale = BODY_GOALS[i].kind === 'position' ? 1000 : 180 / Math.PI; // m -> mm, rad -> °
      return series.map((e) => Math.max(FLOOR_MM, e * scale));
    })]);
  }
}
