// The page: arm reach, missile guidance and full-body views over the wasm core, live numbers, live charts.
import * as THREE from 'three';

import { ArmView } from './armView.js';
import type { ArmSettings } from './armView.js';
import { BodyCharts } from './bodyCharts.js';
import { BodyView, TARGETS } from './bodyView.js';
import type { TargetId } from './bodyView.js';
import { computeCharts } from './charts.js';
import type { ChartState } from './charts.js';
import { BODY_GOALS } from './humanoid.js';
import { IKError, SOLVERS, loadIKCore } from './ikchain.js';
import { MissileView } from './missileView.js';

const $ = <T extends HTMLElement = HTMLElement>(id: string) => document.getElementById(id) as T;

async function main(): Promise<void> {
  const core = await loadIKCore();
  const viewport = $('viewport');
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
  viewport.appendChild(renderer.domElement);

  const solverSelect = $<HTMLSelectElement>('solver');
  for (const s of SOLVERS) solverSelect.add(new Option(s.label, s.id));
  const jointsInput = $<HTMLInputElement>('joints');
  const restartsInput = $<HTMLInputElement>('restarts');
  const settings = (): ArmSettings => ({
    solver: SOLVERS.find((s) => s.id === solverSelect.value)!.kind,
    joints: Number(jointsInput.value),
    jointType: $<HTMLSelectElement>('joint-type').value as 'hinge' | 'ball',
    limits: $<HTMLInputElement>('limits').checked,
    orientation: $<HTMLInputElement>('orientation').checked,
    restarts: Number(restartsInput.value),
  });

  const arm = new ArmView(core, renderer.domElement, settings());
  const missile = new MissileView(core, renderer.domElement);
  const body = new BodyView(core, renderer.domElement, viewport);
  let bodyCharts: BodyCharts | undefined; // made when the body view is first shown (uPlot sizes to its box)
  type View = 'arm' | 'missile' | 'body';
  let view: View = 'arm';
  const setView = (v: View) => {
    view = v;
    arm.setEnabled(v === 'arm');
    missile.setEnabled(v === 'missile');
    body.setEnabled(v === 'body');
    document.querySelectorAll('.tab').forEach((t) => t.classList.toggle('active', (t as HTMLElement).dataset.view === v));
    $('missile-stats').hidden = v !== 'missile';
    $('hint').hidden = v !== 'arm';
    $('arm-controls').hidden = v !== 'arm';
    $('body-controls').hidden = v !== 'body';
    $('body-stats').hidden = v !== 'body';
    $('body-charts').hidden = v !== 'body';
    $('live').hidden = v === 'body';
    $('solver-label').hidden = v === 'body';
    if (v === 'body') bodyCharts ??= new BodyCharts($('chart-body-time'), $('chart-body-error'));
  };
  document.querySelectorAll<HTMLElement>('.tab').forEach((t) => t.addEventListener('click', () => setView(t.dataset.view as View)));

  // The body view's panel: animate or drag, which target the gizmo holds, per-goal errors.
  const bodyTarget = $<HTMLSelectElement>('body-target');
  for (const t of TARGETS) bodyTarget.add(new Option(`${t.label} (level ${t.id === 'hips' ? '1 facing, 3 position' : t.level})`, t.id));
  bodyTarget.value = body.selected;
  const bodyAnimate = $<HTMLInputElement>('body-animate');
  const bodyMode = $<HTMLButtonElement>('body-gizmo-mode');
  const setBodyMode = (mode: 'translate' | 'rotate') => {
    body.gizmo.setMode(mode);
    bodyMode.textContent = `Gizmo: ${mode}`;
  };
  const selectBodyTarget = (id: TargetId) => {
    bodyTarget.value = id;
    body.select(id);
  };
  bodyAnimate.addEventListener('input', () => {
    body.setAnimate(bodyAnimate.checked);
    bodyTarget.disabled = bodyMode.disabled = bodyAnimate.checked;
  });
  bodyTarget.disabled = bodyMode.disabled = true;
  bodyTarget.addEventListener('input', () => selectBodyTarget(bodyTarget.value as TargetId));
  bodyMode.addEventListener('click', () => setBodyMode(body.gizmo.mode === 'translate' ? 'rotate' : 'translate'));
  // A click on a target (not a drag) hands it to the gizmo.
  let downAt: { x: number; y: number } | undefined;
  renderer.domElement.addEventListener('pointerdown', (e) => { downAt = { x: e.clientX, y: e.clientY }; });
  renderer.domElement.addEventListener('pointerup', (e) => {
    if (view !== 'body' || body.animate || !downAt || Math.hypot(e.clientX - downAt.x, e.clientY - downAt.y) > 4) return;
    const r = renderer.domElement.getBoundingClientRect();
    const id = body.pick((e.clientX - r.left) / r.width * 2 - 1, 1 - (e.clientY - r.top) / r.height * 2);
    if (id) selectBodyTarget(id);
  });
  const goalRows = BODY_GOALS.map((g) => {
    const tr = document.createElement('tr');
    tr.innerHTML = `<td>${g.label}</td><td>${g.level}</td><td>–</td>`;
    $('body-goals').appendChild(tr);
    return tr.lastElementChild as HTMLElement;
  });
  // The solve's µs (the core's timer) over the last 60 frames. The median is the solve's cost; the
  // mean also carries the frames the OS preempted mid-solve (a 4 ms time slice on a busy machine
  // adds 70 µs to a 60-frame mean), so the panel shows both.
  const recentUs = () => {
    const us = body.history.us.slice(-60);
    const sorted = [...us].sort((a, b) => a - b);
    const mid = sorted.length >> 1;
    return { frames: us.length, mean: us.reduce((a, b) => a + b, 0) / us.length,
             median: sorted.length % 2 ? sorted[mid] : (sorted[mid - 1] + sorted[mid]) / 2 };
  };
  // The goal errors' worst over the last 60 frames (about a second), per goal.
  const worstRecent = () => body.history.errors.map((e) => (e.length ? Math.max(...e.slice(-60)) : NaN));
  const showGoalError = (i: number, e: number) => !Number.isFinite(e) ? '–'
    : BODY_GOALS[i].kind === 'position' ? `${(e * 1000).toFixed(4)} mm` : `${(e * 180 / Math.PI).toFixed(4)}°`;
  setView(location.hash === '#body' ? 'body' : 'arm');

  const applySettings = () => {
    $('joints-out').textContent = jointsInput.value;
    $('restarts-out').textContent = restartsInput.value;
    const s = settings();
    missile.solver = s.solver;
    try {
      arm.rebuild(s);
    } catch (e) {
      $('live-message').textContent = e instanceof IKError ? e.message : String(e);
    }
  };
  for (const id of ['solver', 'joints', 'joint-type', 'limits', 'orientation', 'restarts']) $(id).addEventListener('input', applySettings);
  const modeButton = $<HTMLButtonElement>('gizmo-mode');
  const setMode = (mode: 'translate' | 'rotate') => {
    arm.gizmo.setMode(mode);
    modeButton.textContent = `Gizmo: ${mode}`;
  };
  modeButton.addEventListener('click', () => setMode(arm.gizmo.mode === 'translate' ? 'rotate' : 'translate'));
  window.addEventListener('keydown', (e) => {
    if (view === 'body') {
      if (e.key === 'r') setBodyMode('rotate');
      if (e.key === 't') setBodyMode('translate');
      return;
    }
    if (e.key === 'r') setMode('rotate');
    if (e.key === 't') setMode('translate');
  });

  const resize = () => {
    const w = viewport.clientWidth;
    const h = viewport.clientHeight;
    renderer.setSize(w, h);
    for (const c of [arm.camera, missile.camera]) {
      c.aspect = w / h;
      c.updateProjectionMatrix();
    }
    body.resize(w, h);
  };
  window.addEventListener('resize', resize);
  resize();

  const fmt = (v: number, digits = 3) => (Number.isFinite(v) ? v.toExponential(digits - 1) : '–');
  let last = performance.now();
  let shownAt = 0;
  const frame = (now: number) => {
    const dt = Math.min(0.05, (now - last) / 1000);
    last = now;
    if (view === 'body') {
      body.update(dt);
      if (now - shownAt > 100) {
        shownAt = now;
        const us = recentUs();
        $('b-reason').textContent = body.lastReason;
        $('b-iterations').textContent = String(body.lastIterations);
        // Not cross-origin isolated, Chromium's timer steps by 100 µs: the median of such
        // readings is a step, not the solve; their mean still averages out.
        $('b-us').textContent = !us.frames ? '–' : window.crossOriginIsolated ? us.median.toFixed(1) : '– (coarse timer)';
        $('b-us-mean').textContent = us.frames ? us.mean.toFixed(1) : '–';
        worstRecent().forEach((e, i) => { goalRows[i].textContent = showGoalError(i, e); });
        bodyCharts?.update(body);
      }
      body.render(renderer);
      requestAnimationFrame(frame);
      return;
    }
    if (view === 'arm') arm.update();
    else missile.update(dt);
    const r = view === 'arm' ? arm.lastResult : missile.lastResult;
    if (r && now - shownAt > 100) {
      shownAt = now;
      const unit = view === 'arm' ? 'm' : 'rad';
      $('live-reason').textContent = r.reason;
      $('live-error').textContent = `${fmt(r.finalError)} ${unit}`;
      $('live-tolerance').textContent = `${fmt(view === 'arm' ? arm.chainTolerance : 1e-4, 1)} ${unit}`;
      $('live-iterations').textContent = String(r.iterations);
      $('live-restarts').textContent = String(r.restarts);
      $('live-us').textContent = (view === 'arm' ? arm.meanSolveUs : missile.meanSolveUs).toFixed(1);
      $('live-message').textContent = r.message;
      $('m-aim').textContent = `${(missile.meanAimErrorRad * 180 / Math.PI).toFixed(3)}°`;
      $('m-lead').textContent = missile.lead ? 'intercept point' : 'no intercept: the target itself';
      $('m-shots').textContent = String(missile.shots);
      $('m-hits').textContent = String(missile.hits);
    }
    renderer.render(view === 'arm' ? arm.scene : missile.scene, view === 'arm' ? arm.camera : missile.camera);
    requestAnimationFrame(frame);
  };
  requestAnimationFrame(frame);

  const charts: ChartState = { complete: false, convergence: [], cells: [], precision: [], speed: [], plots: {} };
  // For the end-to-end test (tests/e2e/) and the curious: the page's state, read-only.
  const hook = {
    ready: true,
    crossOriginIsolated: window.crossOriginIsolated,
    charts,
    get live() {
      const r = arm.lastResult!;
      return { solver: SOLVERS.find((s) => s.kind === settings().solver)!.id, reason: r.reason, error: r.finalError,
               iterations: r.iterations, restarts: r.restarts, maxRestarts: arm.maxRestarts, tolerance: arm.chainTolerance, usPerSolve: arm.meanSolveUs, message: r.message };
    },
    get missile() {
      return { shots: missile.shots, hits: missile.hits, meanAimErrorDeg: missile.meanAimErrorRad * 180 / Math.PI, lead: missile.lead };
    },
    get target() { return arm.target.position.toArray(); },
    // Where the target (the gizmo's centre) is on screen, in page pixels.
    targetScreen() {
      const p = arm.target.position.clone().project(arm.camera);
      const rect = renderer.domElement.getBoundingClientRect();
      return { x: rect.left + (p.x + 1) / 2 * rect.width, y: rect.top + (1 - p.y) / 2 * rect.height };
    },
    // The body view: the last solve, each goal's worst error over the last 60 frames (m or rad),
    // the lowest the hips went, what the panel and the charts show.
    get body() {
      const us = recentUs();
      return {
        reason: body.lastReason, iterations: body.lastIterations, message: body.lastMessage,
        usPerFrame: us.mean, usMedian: us.median, frames: body.history.t.length,
        goals: BODY_GOALS.map((g, i) => ({ label: g.label, level: g.level, kind: g.kind, error: body.goalErrors[i], worstRecent: worstRecent()[i] })),
        lowestHips: body.lowestHips, animate: body.animate,
        shown: { reason: $('b-reason').textContent, us: $('b-us').textContent, usMean: $('b-us-mean').textContent,
                 goals: goalRows.map((r) => r.textContent) },
        plotted: bodyCharts ? [bodyCharts.time, bodyCharts.error].map((p) => p.data.slice(1).map((s) => s.length)) : [],
        canvases: document.querySelectorAll('#body-charts canvas').length,
      };
    },
    // Jumps the animation to t seconds (the screenshot shows the reach).
    bodyTime(t: number) { body.jumpTo(t); },
    bodyTarget(id: TargetId) { return body.targets[id].position.toArray(); },
    bodyTargetScreen(id: TargetId) {
      const p = body.targets[id].position.clone().project(body.camera);
      const rect = renderer.domElement.getBoundingClientRect();
      return { x: rect.left + (p.x + 1) / 2 * rect.width, y: rect.top + (1 - p.y) / 2 * rect.height };
    },
    view: setView,
  };
  (window as unknown as { __ikdemo: typeof hook }).__ikdemo = hook;
  await computeCharts(core, charts, (s) => { $('charts-status').textContent = s; });
}

main().catch((e) => {
  document.body.insertAdjacentHTML('afterbegin', `<pre style="color:#f66">IKChain demo failed to start: ${String(e)}</pre>`);
  throw e;
});
