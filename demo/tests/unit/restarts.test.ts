// Restarts, escapes and the time budget through the wrapper (Options.maxRestarts / restartSeed /
// timeBudgetUsec; SolveResult.restarts / escapes / budgetExhausted), against the real module.
// The core's own tests of the same behaviour: tests/core/restarts_test.cpp.
import { test } from 'node:test';
import assert from 'node:assert/strict';

import { SolverKind, loadIKCore } from '../../src/ikchain.js';
import type { Chain, Goal, JointSpec, Quat, SolveResult, Vec3 } from '../../src/ikchain.js';

const core = await loadIKCore();
const NEWTON = [SolverKind.DLS, SolverKind.JacobianPinv, SolverKind.BFGS];
const dist = (a: Vec3, b: Vec3) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
const angle = (a: Quat, b: Quat) =>
  2 * Math.acos(Math.min(1, Math.abs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3])));

// A 7-hinge arm with the Franka Panda's joint pattern and limit ranges (as the core's restarts
// test): hinges about the bone (Y) and across it (Z) alternately, every one limited.
const LINKS = [0.333, 0.316, 0.0825, 0.384, 0.088, 0.107, 0.1];
const LOWER = [-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973];
const UPPER = [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973];
const MIDDLE = LOWER.map((l, i) => 0.5 * (l + UPPER[i]));

function limitedArm7(): Chain {
  const joints: JointSpec[] = LINKS.map((_, i) => ({
    type: 'hinge',
    offset: [0, i === 0 ? 0 : LINKS[i - 1], 0],
    axis: i % 2 === 0 ? [0, 1, 0] : [0, 0, 1],
    limits: { min: LOWER[i], max: UPPER[i] },
  }));
  return core.createChain(joints, [0, LINKS[6], 0]);
}

// Full poses (tip position, and the last joint's rotation weighted by L^2) reached by seeded random
// in-limit poses: every one is reachable, so a miss is the solver's, not the goal's.
function fullPoses(arm: Chain, count: number, seed: number): Goal[][] {
  let s = seed;
  const random = () => { s = (s * 1103515245 + 12345) % 2147483648; return s / 2147483648; };
  const L = arm.totalLength;
  const out: Goal[][] = [];
  for (let t = 0; t < count; ++t) {
    arm.setParams(LOWER.map((l, i) => l + (UPPER[i] - l) * random()));
    const f = arm.frames();
    out.push([{ kind: 'position', target: f.tip },
              { kind: 'orientation', quaternion: f.joints[6].quaternion, weight: L * L }]);
  }
  return out;
}

function solveFrom(arm: Chain, start: readonly number[], kind: SolverKind): { r: SolveResult; p: number[] } {
  arm.setParams(start);
  const r = arm.solve(kind);
  return { r, p: Array.from(arm.params()) };
}

test('restarts are off by default, as in the core', () => {
  const arm = limitedArm7();
  assert.equal(arm.options.maxRestarts, 0);
  assert.equal(arm.options.restartSeed, 1);
  assert.equal(arm.options.timeBudgetUsec, 0);
  arm.dispose();
});

test('restarts: full poses a single run leaves unsolved on the limited arm converge, within the limits', () => {
  const arm = limitedArm7();
  const L = arm.totalLength;
  const tolerance = 1e-5 * L;
  arm.setOptions({ positionTolerance: tolerance, orientationTolerance: 1e-4, timeCapUsec: 0 }); // no wall-clock cut
  const poses = fullPoses(arm, 40, 12345);
  let unsolvedAlone = 0;
  let restarted = 0;
  for (const kind of NEWTON) {
    for (const goals of poses) {
      arm.setGoals(goals);
      arm.setOptions({ maxRestarts: 0 });
      const alone = solveFrom(arm, MIDDLE, kind).r;
      assert.equal(alone.restarts, 0);
      arm.setOptions({ maxRestarts: 20, restartSeed: 1 });
      const { r, p } = solveFrom(arm, MIDDLE, kind);
      const what = `${SolverKind[kind]}, goal ${goals[0].kind === 'position' ? goals[0].target : ''}`;
      assert.equal(r.reason, 'converged', `${what}: ${r.reason} after ${r.restarts} restarts`);
      if (alone.reason === 'converged' && alone.escapes === 0) {
        // The first run is the same run: nothing to restart. (A run that escaped may run otherwise
        // when restarts follow: the core then leaves a creep or a nearby trap to them.)
        assert.equal(r.restarts, 0, what);
        assert.equal(r.iterations, alone.iterations, what);
      }
      if (alone.reason !== 'converged') ++unsolvedAlone;
      if (r.restarts > 0) ++restarted;
      p.forEach((v, i) => assert.ok(v >= LOWER[i] - 1e-9 && v <= UPPER[i] + 1e-9, `${what}: joint ${i} at ${v}`));
      // The core's claim, checked by its forward kinematics from the returned params.
      const f = arm.frames();
      assert.ok(goals[0].kind === 'position' && dist(f.tip, goals[0].target) <= tolerance, what);
      assert.ok(goals[1].kind === 'orientation' && angle(f.joints[6].quaternion, goals[1].quaternion) <= 1e-4 + 1e-9, what);
    }
  }
  assert.ok(unsolvedAlone >= 3 && restarted >= 3,
            `${unsolvedAlone} runs unsolved alone, ${restarted} restarted: the case no longer exercises restarts`);
  arm.dispose();
});

test('restarts: the same restartSeed gives bitwise the same result, another seed other restarts', () => {
  const arm = limitedArm7();
  arm.setOptions({ positionTolerance: 1e-5 * arm.totalLength, orientationTolerance: 1e-4, maxIterations: 30, timeCapUsec: 0 });
  let compared = 0;
  let differ = 0;
  for (const goals of fullPoses(arm, 40, 777)) {
    arm.setGoals(goals);
    arm.setOptions({ maxRestarts: 20, restartSeed: 1 });
    const a = solveFrom(arm, MIDDLE, SolverKind.DLS);
    const b = solveFrom(arm, MIDDLE, SolverKind.DLS);
    assert.deepEqual(b.p, a.p);
    assert.equal(b.r.iterations, a.r.iterations);
    assert.equal(b.r.restarts, a.r.restarts);
    assert.equal(b.r.escapes, a.r.escapes);
    assert.equal(b.r.finalError, a.r.finalError);
    if (a.r.restarts === 0) continue;
    arm.setOptions({ restartSeed: 4242 });
    const other = solveFrom(arm, MIDDLE, SolverKind.DLS);
    ++compared;
    if (other.p.some((v, i) => v !== a.p[i])) ++differ;
  }
  assert.ok(compared > 0, 'no solve restarted');
  assert.ok(differ > 0, `another seed gave the same pose in all ${compared} restarted solves`);
  arm.dispose();
});

// One hinge limited to a full turn, [-pi, pi]; the solution just inside +pi, the start just inside
// -pi: the shorter way runs into the -pi bound. A solver stops there (stalled), or leaves it inside
// its run by an escape; one restart (the stopped pose wrapped across the bound) solves it.
test('restarts and escapes: a hinge stopped on a full-turn bound', () => {
  const c = core.createChain([{ type: 'hinge', offset: [0, 0, 0], axis: [0, 0, 1], limits: { min: -Math.PI, max: Math.PI } }],
                             [0, 1, 0]);
  const solution = Math.PI - 0.05;
  c.setGoals([{ kind: 'position', target: [-Math.sin(solution), Math.cos(solution), 0] }]);
  const start = [-Math.PI + 0.1];
  let stalled = 0;
  for (const kind of NEWTON) {
    c.setOptions({ maxRestarts: 0 });
    const alone = solveFrom(c, start, kind);
    if (alone.r.reason === 'converged') {
      assert.ok(alone.r.escapes >= 1, `${SolverKind[kind]} left the bound without an escape`);
      assert.ok(Math.abs(alone.p[0] - solution) <= 1e-4, `${SolverKind[kind]}: ${alone.p[0]}`);
    } else {
      ++stalled;
      assert.equal(alone.r.reason, 'stalled', SolverKind[kind]);
      assert.ok(Math.abs(alone.p[0] + Math.PI) <= 1e-6, `${SolverKind[kind]} stopped at ${alone.p[0]}, not on -pi`);
    }
    for (const restartSeed of [1, 2, 3]) {
      c.setOptions({ maxRestarts: 1, restartSeed });
      const { r, p } = solveFrom(c, start, kind);
      assert.equal(r.reason, 'converged', `${SolverKind[kind]}, seed ${restartSeed}`);
      assert.equal(r.restarts, alone.r.reason === 'converged' ? 0 : 1, `${SolverKind[kind]}, seed ${restartSeed}`);
      assert.ok(Math.abs(p[0] - solution) <= 1e-4, `${SolverKind[kind]}, seed ${restartSeed}: ${p[0]}`);
      assert.ok(dist(c.frames().tip, [-Math.sin(solution), Math.cos(solution), 0]) <= 1e-5);
    }
  }
  assert.ok(stalled >= 1, 'no solver stopped on the bound: the case no longer exercises a restart');
  c.dispose();
});

test('time budget: an ordinary solve is within it; a budget far below one iteration stops before the first', () => {
  const c = core.createBenchChain(10);
  const target = core.benchTargets(10, 1)[0];
  c.setGoals([{ kind: 'position', target }]);
  c.setOptions({ warmStart: false, positionTolerance: 1e-4 });
  const ordinary = c.solve(SolverKind.DLS);
  assert.equal(ordinary.reason, 'converged');
  assert.equal(ordinary.budgetExhausted, false);
  assert.equal(ordinary.restarts, 0);

  // Checked before every iteration, the first included (issue 16, item 6): 1 ns is spent before
  // the first, so the solve ends at its start pose; the tolerance is never met.
  c.setOptions({ timeBudgetUsec: 1e-3, positionTolerance: 1e-300, maxRestarts: 5 });
  const spent = c.solve(SolverKind.DLS);
  assert.equal(spent.budgetExhausted, true);
  assert.equal(spent.reason, 'max_iterations');
  assert.equal(spent.iterations, 0);
  assert.equal(spent.restarts, 0, 'the budget stops restarts too');
  assert.equal(spent.finalError, spent.initialError, 'nothing ran: the start pose is kept');
  c.dispose();
});

test('bad values: the core refuses them naming the field, the pose untouched; non-integers never reach it', () => {
  const c = core.createBenchChain(3);
  c.setGoals([{ kind: 'position', target: core.benchTargets(3, 1)[0] }]);
  const before = c.params();
  const refused = (expected: RegExp) => {
    const r = c.solve(SolverKind.DLS);
    assert.equal(r.reason, 'invalid_input');
    assert.equal(r.usable, false);
    assert.match(r.message, expected);
    assert.deepEqual(c.params(), before);
  };
  c.setOptions({ maxRestarts: -1 });
  refused(/max_restarts must be >= 0 \(0 = none\), got -1/);
  c.setOptions({ maxRestarts: 0, timeBudgetUsec: -5 });
  refused(/time_budget_usec must be >= 0 \(0 = no budget\), got -5/);
  c.setOptions({ timeBudgetUsec: NaN });
  refused(/time_budget_usec must be >= 0 \(0 = no budget\), got nan/);
  c.setOptions({ timeBudgetUsec: 0 });
  assert.equal(c.solve(SolverKind.DLS).reason, 'converged');

  // embind would truncate 2.5 and wrap -1 for an unsigned: the wrapper refuses, options unchanged.
  assert.throws(() => c.setOptions({ maxRestarts: 2.5 }), /setOptions: maxRestarts must be an integer in -2147483648\.\.2147483647, got 2\.5/);
  assert.throws(() => c.setOptions({ restartSeed: -1 }), /restartSeed must be an integer in 0\.\.4294967295, got -1/);
  assert.throws(() => c.setOptions({ restartSeed: 2 ** 32 }), /restartSeed must be an integer/);
  assert.throws(() => c.setOptions({ maxIterations: 1e10 }), /maxIterations must be an integer/);
  assert.equal(c.options.maxRestarts, 0);
  assert.equal(c.options.restartSeed, 1);
  c.setOptions({ restartSeed: 2 ** 32 - 1 });
  assert.equal(c.solve(SolverKind.DLS).reason, 'converged');
  c.dispose();
});
