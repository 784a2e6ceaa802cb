// The body view's frames without the page: the animated targets into the goals, one DLS solve per
// frame, warm, with the page's options (humanoid.ts's BODY_OPTIONS), under Node against the module `scons web`
// built. Prints the core's µs per solve (its timer, elapsedUs), the wall time around the call and
// the iterations, so the page's figure can be told apart from the solve's own cost.
//
//   node tests/bench/body_frames.mjs [--fps N] [--seconds S] [--posture-iterations N] [--idle MS]
//                                    [--record FILE]
//
// --fps: frames per second of animation time (the page's dt; headless Chromium with SwiftShader
// draws about 10 frames a second and the page caps dt at 0.05 s, i.e. 20). --idle MS: between two
// frames, a 32 MB pass over memory and MS ms asleep, as a page's drawing and waiting for the next
// frame leave the caches (untimed). The first second of frames is not counted (the engine tiers up).
// --record FILE: every call on the raw WebTree, one per line, for bench/web_body_replay.cpp (the
// same solves natively: `scons -Q build/bench_obj/web_body_replay`).
import { spawnSync } from 'node:child_process';
import { copyFileSync, mkdirSync, writeFileSync } from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const demoDir = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const args = process.argv.slice(2);
const opt = (name, fallback) => { const i = args.indexOf(name); return i >= 0 ? Number(args[i + 1]) : fallback; };
const recordTo = args.includes('--record') ? args[args.indexOf('--record') + 1] : undefined;
const fps = opt('--fps', 60);
const seconds = opt('--seconds', 32);
const idleMs = opt('--idle', 0);

// The wrapper and humanoid.ts compiled as the unit tests compile them (tests/unit/run.sh).
const tsc = spawnSync(process.execPath, [path.join(demoDir, 'node_modules/typescript/bin/tsc'), '-p', 'tsconfig.test.json'],
                      { cwd: demoDir, stdio: 'inherit' });
if (tsc.status !== 0) process.exit(1);
mkdirSync(path.join(demoDir, '.test-out/src/wasm'), { recursive: true });
copyFileSync(path.join(demoDir, 'src/wasm/ikchain_wasm.mjs'), path.join(demoDir, '.test-out/src/wasm/ikchain_wasm.mjs'));
const { SolverKind, loadIKCore } = await import(path.join(demoDir, '.test-out/src/ikchain.js'));
const { BODY_OPTIONS, BODY_POSTURE_STIFFNESS, E, HUMANOID, animatedTargets, bodyGoals, relaxedPose, setBodyGoalValues } =
  await import(path.join(demoDir, '.test-out/src/humanoid.js'));
const postureIterations = opt('--posture-iterations', BODY_OPTIONS.postureIterations);

const core = await loadIKCore();
// Recording: the raw object's calls (numbers written to round-trip), each solve with the iterations
// the wasm took.
const calls = [];
if (recordTo) {
  const raw = core.module.WebTree.prototype;
  for (const name of ['addBall', 'addHinge', 'addEffector', 'setFloatingRoot', 'build', 'clearGoals', 'addPositionGoal',
                      'addOrientationGoal', 'addAimGoal', 'setPosture', 'setPostureIterations', 'setParams', 'setMaxIterations',
                      'setTolerances', 'setWarmStart', 'setTimeBudgetUsec', 'setTimeCapUsec', 'setGoalPosition',
                      'setGoalOrientation', 'setGoalAimDirection', 'solve']) {
    const call = raw[name];
    raw[name] = function (...a) {
      const numbers = a.flatMap((x) => (typeof x === 'boolean' ? [Number(x)] : typeof x === 'number' ? [x] : Array.from(x)));
      const r = call.apply(this, a);
      calls.push(`${name} ${numbers.map(String).join(' ')}${name === 'solve' ? ` # ${this.lastIterations()}` : ''}`);
      return r;
    };
  }
}
const body = core.createTree(HUMANOID);
const pose = relaxedPose();
body.setParams(pose);
body.setPosture(pose, BODY_POSTURE_STIFFNESS);
body.setOptions({ ...BODY_OPTIONS, postureIterations });
const head = 7 * HUMANOID.joints.length + 3 * E.head;
const a0 = animatedTargets(0);
const h0 = body.frames().effectors[E.head];
body.setGoals(bodyGoals(a0.feet, a0.feetRotation, a0.hipsRotation, a0.hands, [a0.look[0] - h0[0], a0.look[1] - h0[1], a0.look[2] - h0[2]], a0.hips));

const junk = new Float64Array(32 << 17); // 32 MB
const coreUs = [];
const wallUs = [];
const iterations = [];
const frames = Math.round(seconds * fps);
for (let k = 0; k <= frames; ++k) {
  if (idleMs > 0) {
    for (let i = 0; i < junk.length; i += 8) junk[i] += 1;
    await new Promise((r) => setTimeout(r, idleMs));
  }
  // What BodyView.update does before its solve.
  const a = animatedTargets(k / fps);
  const f0 = body.framesArray();
  setBodyGoalValues(body, a, [a.look[0] - f0[head], a.look[1] - f0[head + 1], a.look[2] - f0[head + 2]]);
  const t0 = performance.now();
  body.solveFast(SolverKind.DLS);
  const t1 = performance.now();
  if (k < fps) continue;
  coreUs.push(body.lastElapsedUs);
  wallUs.push((t1 - t0) * 1000);
  iterations.push(body.lastIterations);
}
body.dispose();
if (recordTo) writeFileSync(recordTo, calls.join('\n') + '\n');

const sorted = (v) => [...v].sort((x, y) => x - y);
const at = (v, p) => sorted(v)[Math.min(v.length - 1, Math.floor(p * v.length))];
const mean = (v) => v.reduce((x, y) => x + y, 0) / v.length;
const f1 = (x) => x.toFixed(1);
console.log(`body frames: ${coreUs.length} at ${fps} fps, posture iterations ${postureIterations}${idleMs ? `, idle ${idleMs} ms + 32 MB pass between frames` : ''}`);
console.log(`  core us per solve: median ${f1(at(coreUs, 0.5))}, mean ${f1(mean(coreUs))}, p90 ${f1(at(coreUs, 0.9))}, p99 ${f1(at(coreUs, 0.99))}`);
console.log(`  wall us around the call: median ${f1(at(wallUs, 0.5))}, mean ${f1(mean(wallUs))}`);
console.log(`  iterations: mean ${mean(iterations).toFixed(2)}, median ${at(iterations, 0.5)}, max ${Math.max(...iterations)}; ` +
            `us per iteration ${(mean(coreUs) / mean(iterations)).toFixed(1)} (means), median over solves ${f1(at(coreUs.map((u, i) => u / Math.max(1, iterations[i])), 0.5))}`);
