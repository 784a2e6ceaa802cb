// The tree API through the wasm module (src/wasm/web_tree.hpp) on the page's humanoid
// (src/humanoid.ts): forward kinematics, priority levels, the floating root, the posture, tracking
// the body view's animated targets, bad input by name.
import { test } from 'node:test';
import assert from 'node:assert/strict';

import { IKError, SolverKind, loadIKCore } from '../../src/ikchain.js';
import type { Tree, Vec3 } from '../../src/ikchain.js';
import { BODY_GOALS, BODY_OPTIONS, BODY_POSTURE_STIFFNESS, CYCLE_S, E, HUMANOID, J, animatedTargets, bodyGoals, dofCount, relaxedPose, setBodyGoalValues } from '../../src/humanoid.js';
import type { BodyTargets } from '../../src/humanoid.js';

const core = await loadIKCore();
const dist = (a: Vec3, b: Vec3) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

function makeBody(): Tree {
  const body = core.createTree(HUMANOID);
  const pose = relaxedPose();
  body.setParams(pose);
  body.setPosture(pose, BODY_POSTURE_STIFFNESS);
  body.setOptions({ ...BODY_OPTIONS, timeCapUsec: 0 }); // the page's options
  return body;
}

function lookDirection(body: Tree, look: Vec3): Vec3 {
  const head = body.frames().effectors[E.head];
  return [look[0] - head[0], look[1] - head[1], look[2] - head[2]];
}

const goalsOf = (body: Tree, a: BodyTargets, hands = a.hands) =>
  bodyGoals(a.feet, a.feetRotation, a.hipsRotation, hands, lookDirection(body, a.look), a.hips);

test('humanoid tree: 20 joints, 55 DOFs with the floating root, 6 effectors; the T-pose by FK', () => {
  const body = core.createTree(HUMANOID);
  assert.equal(body.jointCount, 20);
  assert.equal(body.dofCount, dofCount(HUMANOID));
  assert.equal(body.dofCount, 3 + 16 * 3 + 4);
  assert.equal(body.effectorCount, 6);
  const f = body.frames();
  assert.deepEqual(f.joints[J.hips].position, [0, 0.75, 0]);
  const close = (a: Vec3, b: Vec3) => assert.ok(dist(a, b) < 1e-12, `${a} != ${b}`);
  close(f.joints[J.head].position, [0, 1.25, 0]);
  close(f.effectors[E.lHand], [0.68, 1.15, 0]); // shoulder 0.05 + 0.05 + 0.25 + 0.25 + palm 0.08
  close(f.effectors[E.rFoot], [-0.1, 0, 0.05]); // the sole on the floor
  body.dispose();
});

test('tracking the animated targets over two cycles: every level 1 and 2 goal met each frame, the body crouches', () => {
  const body = makeBody();
  const a0 = animatedTargets(0);
  body.setGoals(goalsOf(body, a0));
  let lowestHips = Infinity;
  let worst = 0;
  let worstAt = '';
  const frames = 2 * CYCLE_S * 30;
  for (let k = 0; k <= frames; ++k) {
    const t = k / 30;
    const a = animatedTargets(t);
    setBodyGoalValues(body, a, lookDirection(body, a.look));
    const reason = body.solveFast(SolverKind.DLS);
    assert.notEqual(reason, 'invalid_input');
    const errors = body.goalErrors();
    errors.forEach((e, i) => {
      if (BODY_GOALS[i].level > 2) return; // the hips' hint gives way by design
      // The look's direction comes from the last frame's head: the new pose moves the head a little.
      const bound = BODY_GOALS[i].kind === 'position' ? 1e-3 : BODY_GOALS[i].kind === 'aim' ? 2e-2 : 1e-3;
      if (e / bound > worst) { worst = e / bound; worstAt = `${BODY_GOALS[i].label} at t=${t.toFixed(2)}: ${e}`; }
    });
    lowestHips = Math.min(lowestHips, body.frames().effectors[E.hips][1]);
  }
  assert.ok(worst < 1, `worst goal error over its bound: ${worstAt}`);
  assert.ok(lowestHips < 0.75 - 0.15, `the hips went down to ${lowestHips} m only (standing: 0.75)`);
  body.dispose();
});

test('levels: a hand target out of reach leaves level 2 unmet, the feet (level 1) stay planted', () => {
  const body = makeBody();
  const a = animatedTargets(0);
  body.setGoals(goalsOf(body, a, [[0.5, 2.6, 0.3], a.hands[1]]));
  let r = body.solve();
  for (let i = 0; i < 5; ++i) r = body.solve();
  assert.equal(r.levelMet[0], true);
  assert.equal(r.levelMet[1], false);
  assert.ok(r.goalErrors[0] < 1e-4 && r.goalErrors[2] < 1e-4, `feet off by ${r.goalErrors[0]}, ${r.goalErrors[2]}`);
  assert.ok(r.goalErrors[5] > 0.5, `left hand error ${r.goalErrors[5]}`);
  body.dispose();
});

test('bad input is named: a goal level out of range, an unknown effector, a short posture, NaN params', () => {
  const body = makeBody();
  const a = animatedTargets(0);
  const goals = goalsOf(body, a);
  const before = Array.from(body.params());
  body.setGoals([...goals.slice(0, 7), { ...goals[7], level: 9 }, goals[8]]);
  let r = body.solve();
  assert.equal(r.reason, 'invalid_input');
  assert.match(r.message, /level/);
  assert.deepEqual(Array.from(body.params()), before);
  body.setGoals([{ kind: 'position', target: [0, 0, 0], effector: 17, level: 1 }]);
  r = body.solve();
  assert.equal(r.reason, 'invalid_input');
  assert.match(r.message, /effector/);
  assert.throws(() => body.setPosture([0, 0], 0.1), (e: unknown) => e instanceof IKError && /posture: expected 55/.test(e.message));
  assert.throws(() => body.setPosture(relaxedPose(), 2), (e: unknown) => e instanceof IKError && /stiffness/.test(e.message));
  assert.throws(() => body.setParams(new Array(55).fill(NaN)), (e: unknown) => e instanceof IKError && /not finite/.test(e.message));
  assert.throws(() => core.createTree({ joints: [{ name: 'a', type: 'ball', parent: 3, offset: [0, 0, 0] }], effectors: [] }),
                (e: unknown) => e instanceof IKError && /parent/.test(e.message));
  body.dispose();
});
