// The page: arm reach and missile guidance views over the wasm core, live numbers, live charts.
import * as THREE from 'three';

import { ArmView } from './armView.js';
import type { ArmSettings } from './armView.js';
import { computeCharts } from './charts.js';
import type { ChartState } from './charts.js';
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
  let view: 'arm' | 'missile' = 'arm';
  const setView = (v: 'arm' | 'missile') => {
    view = v;
    arm.setEnabled(v === 'arm');
    missile.setEnabled(v === 'missile');
    document.querySelectorAll('.tab').forEach((t) => t.classList.toggle('active', (t as HTMLElement).dataset.view === v));
    $('missile-stats').hidden = v !== 'missile';
    $('hint').hidden = v !== 'arm';
    $('arm-controls').hidden = v !== 'arm';
  };
  document.querySelectorAll<HTMLElement>('.tab').forEach((t) => t.addEventListener('click', () => setView(t.dataset.view as 'arm' | 'missile')));
  setView('arm');

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
  };
  window.addEventListener('resize', resize);
  resize();

  const fmt = (v: number, digits = 3) => (Number.isFinite(v) ? v.toExponential(digits - 1) : '–');
  let last = performance.now();
  let shownAt = 0;
  const frame = (now: number) => {
    const dt = Math.min(0.05, (now - last) / 1000);
    last = now;
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
    view: setView,
  };
  (window as unknown as { __ikdemo: typeof hook }).__ikdemo = hook;
  await computeCharts(core, charts, (s) => { $('charts-status').textContent = s; });
}

main().catch((e) => {
  document.body.insertAdjacentHTML('afterbegin', `<pre style="color:#f66">IKChain demo failed to start: ${String(e)}</pre>`);
  throw e;
});
