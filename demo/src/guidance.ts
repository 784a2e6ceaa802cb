// Missile-guidance math of the demo (not IK: IKChain's aim goal does all the aiming).
export type V3 = [number, number, number];

const dot = (a: V3, b: V3) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const sub = (a: V3, b: V3): V3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a: V3, b: V3): V3 => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const scale = (a: V3, s: number): V3 => [a[0] * s, a[1] * s, a[2] * s];
const cross = (a: V3, b: V3): V3 => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
export const length = (a: V3) => Math.sqrt(dot(a, a));

// Smallest t > 0 with |d + v t| = s t (d: target relative to the launcher, v: target velocity,
// s: projectile speed), i.e. (v.v - s^2) t^2 + 2 (d.v) t + d.d = 0; null when there is none.
export function interceptTime(d: V3, v: V3, s: number): number | null {
  const a = dot(v, v) - s * s;
  const b = 2 * dot(d, v);
  const c = dot(d, d);
  const roots: number[] = [];
  if (Math.abs(a) < 1e-12) {
    if (Math.abs(b) > 1e-12) roots.push(-c / b);
  } else {
    const disc = b * b - 4 * a * c;
    if (disc < 0) return null;
    const sq = Math.sqrt(disc);
    roots.push((-b - sq) / (2 * a), (-b + sq) / (2 * a));
  }
  const positive = roots.filter((t) => t > 1e-9 && Number.isFinite(t));
  return positive.length ? Math.min(...positive) : null;
}

// Where to aim: the lead intercept point, or the target itself when the projectile cannot catch it.
export function leadPoint(launcher: V3, target: V3, targetVelocity: V3, speed: number): { point: V3; lead: boolean } {
  const t = interceptTime(sub(target, launcher), targetVelocity, speed);
  if (t === null) return { point: target, lead: false };
  return { point: add(target, scale(targetVelocity, t)), lead: true };
}

// Proportional navigation: a = N Vc (omega x r_hat), omega = (r x v_rel) / |r|^2 the line-of-sight
// rate, Vc the closing speed; lateral (perpendicular to the missile's velocity), capped at maxAccel.
export function pnAcceleration(missile: V3, missileVelocity: V3, target: V3, targetVelocity: V3,
                               navigationConstant: number, maxAccel: number): V3 {
  const r = sub(target, missile);
  const r2 = dot(r, r);
  if (r2 < 1e-12) return [0, 0, 0];
  const vRel = sub(targetVelocity, missileVelocity);
  const omega = scale(cross(r, vRel), 1 / r2);
  const rHat = scale(r, 1 / Math.sqrt(r2));
  const closing = -dot(r, vRel) / Math.sqrt(r2);
  let a = scale(cross(omega, rHat), navigationConstant * Math.max(closing, 0));
  const speed = length(missileVelocity);
  if (speed > 1e-9) {
    const vHat = scale(missileVelocity, 1 / speed);
    a = sub(a, scale(vHat, dot(a, vHat)));
  }
  const m = length(a);
  return m > maxAccel ? scale(a, maxAccel / m) : a;
}
