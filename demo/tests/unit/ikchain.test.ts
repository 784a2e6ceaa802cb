// Unit tests of the typed wrapper, run by node's test runner against the real wasm module
// (compiled by tsconfig.test.json; the module is the one `scons web` built).
import { test } from 'node:test';
import assert from 'node:assert/strict';

import { IKError, SolverKind, armJoints, loadIKCore } from '../../src/ikchain.js';
import type { Vec3 } from '../../src/ikchain.js';

const core = await loadIKCore();
const dist = (a: Vec3, b: Vec3) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
const NEWTON = [SolverKind.DLS, SolverKind.BFGS, SolverKind.JacobianPinv];

test('bench chain: n hinges with unit links; rest-pose tip at (0, n, 0)', () => {
  const c = core.createBenchChain(10);
  assert.equal(c.jointCount, 10);
  assert.equal(c.dofCount, 10);
  assert.equal(c.totalLength, 10);
  const f = c.frames();
  assert.equal(f.joints.length, 10);
  assert.deepEqual(f.tip, [0, 10, 0]);
  assert.deepEqual(f.joints[3].position, [0, 3, 0]);
  c.dispose();
});

test('every Newton-like solver reaches seeded targets; the FK tip round-trips to the target', () => {
  const c = core.createBenchChain(10);
  c.setOptions({ warmStart: false, positionTolerance: 1e-4, timeCapUsec: 0 }); // iterations alone end a solve
  const targets = core.benchTargets(10, 20);
  assert.equal(targets.length, 20);
  for (const kind of NEWTON) {
    c.setGoals([{ kind: 'position', target: targets[0] }]);
    for (const t of targets) {
      c.setGoalPosition(0, t);
      const r = c.solve(kind);
      assert.equal(r.reason, 'converged', `${SolverKind[kind]} on ${t}: ${r.reason} ${r.message}`);
      const tip = c.frames().tip;
      assert.ok(dist(tip, t) <= 1e-4, `${SolverKind[kind]}: tip ${tip} is ${dist(tip, t)} from ${t}`);
      assert.ok(Math.abs(dist(tip, t) - r.finalPositionError) < 1e-12);
      assert.ok(r.iterations >= 1 && r.iterations <= 100);
      assert.ok(r.initialError > r.finalError);
    }
  }
  c.dispose();
});

test('benchTargets are seeded (same seed, same targets) and reachable (|t| <= n)', () => {
  const a = core.benchTargets(7, 50);
  const b = core.benchTargets(7, 50, 1007);
  const other = core.benchTargets(7, 50, 99);
  assert.deepEqual(a, b);
  assert.notDeepEqual(a, other);
  for (const t of a) assert.ok(Math.hypot(...t) <= 7 + 1e-9);
});

test('hinge limits hold after a solve toward a target behind the arm', () => {
  const spec = { joints: 6, jointType: 'hinge' as const, limits: true };
  const c = core.createArm(spec);
  const { joints } = armJoints(spec);
  c.setGoals([{ kind: 'position', target: [0.5, -3, -1] }]);
  c.setOptions({ maxIterations: 200 });
  for (const kind of [SolverKind.DLS, SolverKind.CCD, SolverKind.FABRIK]) {
    c.resetPose();
    const r = c.solve(kind);
    assert.ok(r.usable, r.message);
    const p = c.params();
    joints.forEach((j, i) => {
      assert.equal(j.type, 'hinge');
      if (j.type === 'hinge' && j.limits) {
        assert.ok(p[i] >= j.limits.min - 1e-9 && p[i] <= j.limits.max + 1e-9,
                  `${SolverKind[kind]}: joint ${i} at ${p[i]} outside [${j.limits.min}, ${j.limits.max}]`);
      }
    });
  }
  c.dispose();
});

test('orientation goal on a ball chain: the tip frame takes the target rotation', () => {
  const c = core.createArm({ joints: 4, jointType: 'ball', limits: false });
  const h = Math.SQRT1_2;
  const q: [number, number, number, number] = [h, 0, 0, h]; // 90 degrees about X
  c.setGoals([{ kind: 'position', target: [1, 2, 1] }, { kind: 'orientation', quaternion: q }]);
  const r = c.solve(SolverKind.DLS);
  assert.equal(r.reason, 'converged', r.message);
  const f = c.frames();
  const last = f.joints[3].quaternion;
  const d = Math.abs(last[0] * q[0] + last[1] * q[1] + last[2] * q[2] + last[3] * q[3]);
  assert.ok(2 * Math.acos(Math.min(1, d)) <= 1e-4 + 1e-9, `tip orientation off by ${2 * Math.acos(Math.min(1, d))} rad`);
  assert.ok(dist(f.tip, [1, 2, 1]) <= 1e-5);
  c.dispose();
});

test('aim goal: the last bone (+Y) points along the requested direction', () => {
  const c = core.createChain([
    { type: 'hinge', offset: [0, 0, 0], axis: [0, 1, 0] },
    { type: 'hinge', offset: [0, 0.6, 0], axis: [1, 0, 0] },
    { type: 'hinge', offset: [0, 1, 0], axis: [1, 0, 0] },
  ], [0, 1.2, 0]);
  const dir: Vec3 = [3, 2, -4];
  c.setGoals([{ kind: 'aim', axis: [0, 1, 0], direction: dir }]);
  const r = c.solve(SolverKind.DLS);
  assert.equal(r.reason, 'converged', r.message);
  const f = c.frames();
  const barrel = [f.tip[0] - f.joints[2].position[0], f.tip[1] - f.joints[2].position[1], f.tip[2] - f.joints[2].position[2]];
  const nb = Math.hypot(...barrel);
  const nd = Math.hypot(...dir);
  const cos = (barrel[0] * dir[0] + barrel[1] * dir[1] + barrel[2] * dir[2]) / (nb * nd);
  assert.ok(Math.acos(Math.min(1, cos)) <= 1e-4 + 1e-9, `barrel off by ${Math.acos(Math.min(1, cos))} rad`);
  c.dispose();
});

test('the precision case: every solver ends 2 from the out-of-reach goal (the lecture: JI 5.85, CCD 3.37, BFGS 2.53)', () => {
  for (const planar of [true, false]) {
    for (const kind of [SolverKind.CCD, SolverKind.FABRIK, SolverKind.JacobianPinv, SolverKind.DLS, SolverKind.BFGS]) {
      const p = core.precisionRun(kind, planar);
      assert.ok(Math.abs(p.distance - 2) <= 1e-4, `${SolverKind[kind]} planar=${planar}: ${p.distance}`);
      assert.equal(p.reason, 'unreachable');
    }
  }
});

test('convergence trace: starts at the rest-pose distance and DLS ends within tolerance', () => {
  const t = core.convergenceTrace(SolverKind.DLS);
  const target = core.benchTargets(10, 1, 4242)[0];
  assert.ok(Math.abs(t.errors[0] - dist(target, [0, 10, 0])) < 1e-12);
  assert.equal(t.stopped, 'converged');
  assert.ok(t.errors[t.errors.length - 1] <= t.tolerance);
  assert.equal(t.tolerance, 1e-4);
  const ccd = core.convergenceTrace(SolverKind.CCD);
  assert.ok(ccd.errors.length > t.errors.length, 'CCD needs more iterations than DLS');
});

test('bad input: clear messages, nothing thrown from the core, pose untouched', () => {
  const c = core.createBenchChain(3);
  c.setGoals([{ kind: 'position', target: [NaN, 0, 0] }]);
  const before = c.params();
  const r = c.solve(SolverKind.DLS);
  assert.equal(r.reason, 'invalid_input');
  assert.equal(r.usable, false);
  assert.match(r.message, /goal 0: target_position \(nan, 0, 0\) must be finite/);
  assert.deepEqual(c.params(), before);

  c.setGoals([{ kind: 'position', target: [1, 1, 0] }]);
  const tb = c.solve(SolverKind.TwoBone);
  assert.equal(tb.reason, 'invalid_input');
  assert.match(tb.message, /2/);

  c.setOptions({ maxIterations: 0 });
  assert.match(c.solve(SolverKind.DLS).message, /max_iterations must be > 0, got 0/);
  c.setOptions({ maxIterations: 100 });

  assert.throws(() => c.setGoalOrientation(0, [0, 0, 0, 1]), /goal 0 is not an orientation goal/);
  assert.throws(() => c.setParams([0, 0]), /setParams: params: expected 3 values/);
  assert.throws(() => c.setParams([0, Infinity, 0]), /value 1 is not finite/);
  const five = Array.from({ length: 5 }, () => ({ kind: 'position' as const, target: [0, 1, 0] as Vec3 }));
  assert.throws(() => c.setGoals(five), /goal 4: goals: at most 4 goals/);
  c.dispose();

  assert.throws(() => core.createChain([{ type: 'hinge', offset: [0, 0, 0], axis: [0, 0, 0] }], [0, 1, 0]),
                (e: unknown) => e instanceof IKError && /chain: joint 0/.test(e.message));
  assert.throws(() => core.createBenchChain(0), /joints must be in 1..1000, got 0/);
  assert.throws(() => core.createArm({ joints: 2.5, jointType: 'hinge', limits: false }), /joints must be an integer/);
});
