import { test } from 'node:test';
import assert from 'node:assert/strict';

import { interceptTime, leadPoint, length, pnAcceleration } from '../../src/guidance.js';
import type { V3 } from '../../src/guidance.js';

test('interceptTime solves |d + v t| = s t exactly', () => {
  // 100 + 9 t^2 = 25 t^2  ->  t = 2.5
  assert.ok(Math.abs(interceptTime([10, 0, 0], [0, 3, 0], 5)! - 2.5) < 1e-12);
  // Head-on, faster projectile: closing at 3 + 7 over 10 -> t = 1.
  assert.ok(Math.abs(interceptTime([10, 0, 0], [-3, 0, 0], 7)! - 1) < 1e-12);
  // Equal speeds (the quadratic degenerates to 2 (d.v) t + d.d = 0): running away along d, no t > 0;
  // coming straight at the launcher, they meet half-way: 100 - 100 t = 0 -> t = 1.
  assert.equal(interceptTime([10, 0, 0], [5, 0, 0], 5), null);
  assert.ok(Math.abs(interceptTime([10, 0, 0], [-5, 0, 0], 5)! - 1) < 1e-12);
  // Faster target running away: no intercept.
  assert.equal(interceptTime([10, 0, 0], [8, 0, 0], 5), null);
});

test('leadPoint: the projectile and the target arrive together; no solution -> the target itself', () => {
  const launcher: V3 = [1, 0, 2];
  const target: V3 = [11, 6, -3];
  const v: V3 = [-2, 1, 3];
  const s = 12;
  const { point, lead } = leadPoint(launcher, target, v, s);
  assert.ok(lead);
  const t = interceptTime([10, 6, -5], v, s)!;
  const flight = length([point[0] - launcher[0], point[1] - launcher[1], point[2] - launcher[2]]) / s;
  assert.ok(Math.abs(flight - t) < 1e-9);
  assert.deepEqual(leadPoint(launcher, target, [100, 0, 0], 1), { point: target, lead: false });
});

test('pnAcceleration is lateral, turns toward the line-of-sight rotation and is capped', () => {
  const a = pnAcceleration([0, 0, 0], [10, 0, 0], [100, 0, 0], [0, 5, 0], 4, 1000);
  assert.ok(Math.abs(a[0]) < 1e-12, 'no component along the velocity');
  assert.ok(a[1] > 0, 'turns toward the target\'s motion');
  // Vc = 10, omega = 5/100 -> |a| = N Vc omega = 4 * 10 * 0.05 = 2
  assert.ok(Math.abs(length(a) - 2) < 1e-12);
  const capped = pnAcceleration([0, 0, 0], [10, 0, 0], [100, 0, 0], [0, 5, 0], 4, 0.5);
  assert.ok(Math.abs(length(capped) - 0.5) < 1e-12);
  assert.deepEqual(pnAcceleration([0, 0, 0], [10, 0, 0], [100, 0, 0], [10, 0, 0], 4, 10), [0, 0, 0]);
});
