// The humanoid of the page's body view, as data for IKCore.createTree: the proportions of Godot's
// SkeletonProfileHumanoid (tests/core/humanoid.hpp: hips at 0.75 m, spine bones 0.1 m, upper and
// lower arm 0.25 m, about 1.45 m tall), the rest rotations identity (a T-pose facing +Z, its left
// on +X), the ankles 8 cm above the soles (the profile puts them at the floor), and the rig
// IKBody.setup_humanoid() makes in Godot: knees hinges 0..165°, elbows 0..150°, spine bones 30° cones
// that bend reluctantly (motion cost 2), a floating root so the hips can crouch.
import type { Quat, Tree, TreeGoal, TreeJointSpec, TreeOptions, TreeSpec, Vec3 } from './ikchain.js';

const deg = Math.PI / 180;

const ball = (name: string, parent: number, offset: Vec3, cone: number, twist: number, twistAxis: Vec3,
              motionCost = 1): TreeJointSpec =>
  ({ name, type: 'ball', parent, offset, motionCost, limits: { cone: cone * deg, twistMin: -twist * deg, twistMax: twist * deg, twistAxis } });
const hinge = (name: string, parent: number, offset: Vec3, axis: Vec3, maxDeg = 150): TreeJointSpec =>
  ({ name, type: 'hinge', parent, offset, axis, limits: { min: 0, max: maxDeg * deg } });

// Joint indices (depth-first: parents first).
export const J = {
  hips: 0, spine: 1, chest: 2, upperChest: 3, neck: 4, head: 5,
  lShoulder: 6, lUpperArm: 7, lLowerArm: 8, lHand: 9,
  rShoulder: 10, rUpperArm: 11, rLowerArm: 12, rHand: 13,
  lUpperLeg: 14, lLowerLeg: 15, lFoot: 16,
  rUpperLeg: 17, rLowerLeg: 18, rFoot: 19,
} as const;

const joints: TreeJointSpec[] = [
  // The floating root: the pelvis tips forward 35° at most (a deeper reach crouches).
  ball('Hips', -1, [0, 0.75, 0], 35, 90, [0, 1, 0]),
  ball('Spine', J.hips, [0, 0.1, 0], 30, 30, [0, 1, 0], 2),
  ball('Chest', J.spine, [0, 0.1, 0], 30, 30, [0, 1, 0], 2),
  ball('UpperChest', J.chest, [0, 0.1, 0], 30, 30, [0, 1, 0], 2),
  ball('Neck', J.upperChest, [0, 0.1, 0], 40, 60, [0, 1, 0]),
  ball('Head', J.neck, [0, 0.1, 0], 40, 60, [0, 1, 0]),
  ball('LeftShoulder', J.upperChest, [0.05, 0.1, 0], 20, 20, [1, 0, 0], 2),
  ball('LeftUpperArm', J.lShoulder, [0.05, 0, 0], 120, 90, [1, 0, 0]),
  // Elbows bend the forearm forward (+Z); knees the shin back (-Z).
  hinge('LeftLowerArm', J.lUpperArm, [0.25, 0, 0], [0, -1, 0]),
  ball('LeftHand', J.lLowerArm, [0.25, 0, 0], 70, 80, [1, 0, 0]),
  ball('RightShoulder', J.upperChest, [-0.05, 0.1, 0], 20, 20, [-1, 0, 0], 2),
  ball('RightUpperArm', J.rShoulder, [-0.05, 0, 0], 120, 90, [-1, 0, 0]),
  hinge('RightLowerArm', J.rUpperArm, [-0.25, 0, 0], [0, 1, 0]),
  ball('RightHand', J.rLowerArm, [-0.25, 0, 0], 70, 80, [-1, 0, 0]),
  ball('LeftUpperLeg', J.hips, [0.1, -0.05, 0], 90, 40, [0, -1, 0]),
  hinge('LeftLowerLeg', J.lUpperLeg, [0, -0.31, 0], [1, 0, 0], 165),
  ball('LeftFoot', J.lLowerLeg, [0, -0.31, 0], 40, 30, [0, -1, 0]),
  ball('RightUpperLeg', J.hips, [-0.1, -0.05, 0], 90, 40, [0, -1, 0]),
  hinge('RightLowerLeg', J.rUpperLeg, [0, -0.31, 0], [1, 0, 0], 165),
  ball('RightFoot', J.rLowerLeg, [0, -0.31, 0], 40, 30, [0, -1, 0]),
];

// Effector indices: hips, hands (the palm), feet (the sole under the ankle, 5 cm forward), head
// (the skull's centre).
export const E = { hips: 0, lHand: 1, rHand: 2, lFoot: 3, rFoot: 4, head: 5 } as const;
export const SOLE_BELOW_ANKLE = 0.08; // m

export const HUMANOID: TreeSpec = {
  joints,
  effectors: [
    { name: 'hips', joint: J.hips, offset: [0, 0, 0] },
    { name: 'left hand', joint: J.lHand, offset: [0.08, 0, 0] },
    { name: 'right hand', joint: J.rHand, offset: [-0.08, 0, 0] },
    { name: 'left foot', joint: J.lFoot, offset: [0, -SOLE_BELOW_ANKLE, 0.05] },
    { name: 'right foot', joint: J.rFoot, offset: [0, -SOLE_BELOW_ANKLE, 0.05] },
    { name: 'head', joint: J.head, offset: [0, 0.1, 0] },
  ],
  floatingRoot: true,
  translationMotionCost: 0.2,
};

// Param layout with a floating root: the root's translation (3), then per joint its rotation
// vector (ball, 3) or angle (hinge, 1), in joint order.
export function dofOffsets(spec: TreeSpec): number[] {
  const out: number[] = [];
  let at = spec.floatingRoot ? 3 : 0;
  for (const j of spec.joints) {
    out.push(at);
    at += j.type === 'ball' ? 3 : 1;
  }
  return out;
}

export function dofCount(spec: TreeSpec): number {
  return spec.joints.reduce((n, j) => n + (j.type === 'ball' ? 3 : 1), spec.floatingRoot ? 3 : 0);
}

// The body view's solve, every frame from the last one's pose (bodyView.ts; the unit tests and
// tests/bench/body_frames.mjs take it too): 60 iterations at most, 0.1 mm and 1e-3 rad, and one
// posture step a frame as IKBody takes (kPostureIterations; the core's
// TreeProblem::posture_iterations): it rides on the frame's first step. The posture's stiffness is
// a frame's share of the way back, so 4 steps leave the body where 1 does (the joints 6 mm apart on
// average) at 5 iterations a frame instead of 2 (docs/web-demo.md, "Speed: the full body").
export const BODY_OPTIONS = {
  maxIterations: 60, positionTolerance: 1e-4, orientationTolerance: 1e-3, warmStart: true, postureIterations: 1,
} as const satisfies TreeOptions;
export const BODY_POSTURE_STIFFNESS = 0.1;

// The posture (and the starting pose): standing, arms hanging 75° down from the T-pose, elbows
// and knees a little bent (a straight knee sits on its limit).
export function relaxedPose(spec: TreeSpec = HUMANOID): Float64Array {
  const q = new Float64Array(dofCount(spec));
  const at = dofOffsets(spec);
  q[at[J.lUpperArm] + 2] = -75 * deg; // about +Z: +X swings down
  q[at[J.rUpperArm] + 2] = 75 * deg;
  q[at[J.lLowerArm]] = 15 * deg;
  q[at[J.rLowerArm]] = 15 * deg;
  q[at[J.lLowerLeg]] = 5 * deg;
  q[at[J.rLowerLeg]] = 5 * deg;
  return q;
}

// The goals, in this order: feet (position and orientation: planted flat) and the hips' side axis
// (+X, an aim goal: the pelvis keeps its facing and stays level sideways, but may tip forward) at
// level 1; the hands and the head's look (its +Z aimed at the look target) at level 2; where the
// hips should be at level 3, a hint that gives way to both levels above (the floating root moves
// the hips: the body crouches toward the hint and bends or rises when a hand or foot needs it).
export interface BodyGoalInfo {
  label: string;
  effector: number;
  level: number;
  kind: 'position' | 'orientation' | 'aim';
}

export const BODY_GOALS: readonly BodyGoalInfo[] = [
  { label: 'left foot', effector: E.lFoot, level: 1, kind: 'position' },
  { label: 'left foot rot.', effector: E.lFoot, level: 1, kind: 'orientation' },
  { label: 'right foot', effector: E.rFoot, level: 1, kind: 'position' },
  { label: 'right foot rot.', effector: E.rFoot, level: 1, kind: 'orientation' },
  { label: 'hips facing', effector: E.hips, level: 1, kind: 'aim' },
  { label: 'left hand', effector: E.lHand, level: 2, kind: 'position' },
  { label: 'right hand', effector: E.rHand, level: 2, kind: 'position' },
  { label: 'head look', effector: E.head, level: 2, kind: 'aim' },
  { label: 'hips (hint)', effector: E.hips, level: 3, kind: 'position' },
];

export const HEAD_FORWARD: Vec3 = [0, 0, 1];
export const HIPS_SIDE: Vec3 = [1, 0, 0];

// v rotated by the unit quaternion q (x, y, z, w).
export function rotate(q: Quat, v: Vec3): Vec3 {
  const [x, y, z, w] = q;
  const tx = 2 * (y * v[2] - z * v[1]), ty = 2 * (z * v[0] - x * v[2]), tz = 2 * (x * v[1] - y * v[0]);
  return [v[0] + w * tx + (y * tz - z * ty), v[1] + w * ty + (z * tx - x * tz), v[2] + w * tz + (x * ty - y * tx)];
}

// `look` is the head's look direction (the look target minus the head's position).
export function bodyGoals(feet: [Vec3, Vec3], feetRotation: Quat, hipsRotation: Quat, hands: [Vec3, Vec3],
                          look: Vec3, hips: Vec3): TreeGoal[] {
  const v = [feet[0], feetRotation, feet[1], feetRotation, rotate(hipsRotation, HIPS_SIDE), hands[0], hands[1], look, hips] as const;
  return BODY_GOALS.map((g, i): TreeGoal => {
    if (g.kind === 'position') return { kind: 'position', target: v[i] as Vec3, effector: g.effector, level: g.level };
    if (g.kind === 'orientation') return { kind: 'orientation', quaternion: v[i] as Quat, effector: g.effector, level: g.level };
    return { kind: 'aim', axis: g.effector === E.hips ? HIPS_SIDE : HEAD_FORWARD, direction: v[i] as Vec3, effector: g.effector, level: g.level };
  });
}

// A frame's goal values, written into a body whose goals bodyGoals() made (BODY_GOALS' order)
// without rebuilding them: what the page does every frame. `look` as bodyGoals()'.
export function setBodyGoalValues(body: Tree, g: Pick<BodyTargets, 'feet' | 'feetRotation' | 'hipsRotation' | 'hands' | 'hips'>,
                                  look: Vec3): void {
  body.setGoalPosition(0, g.feet[0]);
  body.setGoalOrientation(1, g.feetRotation);
  body.setGoalPosition(2, g.feet[1]);
  body.setGoalOrientation(3, g.feetRotation);
  body.setAimDirection(4, rotate(g.hipsRotation, HIPS_SIDE));
  body.setGoalPosition(5, g.hands[0]);
  body.setGoalPosition(6, g.hands[1]);
  body.setAimDirection(7, look);
  body.setGoalPosition(8, g.hips);
}

// --- The animated targets (the view's default; the unit tests track them too)

export interface BodyTargets {
  floor: number; // the floor's height under the feet, m
  feet: [Vec3, Vec3]; // left, right: the soles' targets
  feetRotation: Quat;
  hipsRotation: Quat;
  hips: Vec3; // where the hips should be if the goals above allow it (level 3): lowered as the hand reaches
  hands: [Vec3, Vec3];
  look: Vec3; // the point the head looks at
  crate: Vec3; // the centre of the crate's top, which the right hand reaches for
  reach: number; // 0 = standing, 1 = the right hand on the crate
}

export const CRATE_SIZE = 0.1; // m
export const CYCLE_S = 8; // the reach's period, s

const smooth = (x: number) => x * x * (3 - 2 * x);
const lerp = (a: Vec3, b: Vec3, s: number): Vec3 => [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s];
const yaw = (angle: number): Quat => [0, Math.sin(angle / 2), 0, Math.cos(angle / 2)];

// At time t (s): the floor rises and falls by 10 cm (period 9 s) with the feet planted on it; every
// CYCLE_S the right hand reaches down to a crate on the floor in front (the body crouches: only the
// hips' rotation is pinned) while the left hand, which draws a circle in front of the chest, comes
// down to the left knee; the head follows an orb; the hips sway ±8° about the vertical.
export function animatedTargets(t: number): BodyTargets {
  const floor = 0.1 * (0.5 - 0.5 * Math.cos(2 * Math.PI * t / 9));
  const phase = (t % CYCLE_S) / CYCLE_S; // 0..1: stand, go down, hold, come up, stand
  const reach = smooth(Math.min(1, Math.max(0, Math.sin(Math.PI * phase) * 1.6 - 0.3)));
  const crate: Vec3 = [-0.16, floor + CRATE_SIZE, 0.34];
  const rightHold: Vec3 = [-0.3, 0.78 + floor, 0.12];
  const w = 1.3 * t;
  const circle: Vec3 = [0.24 + 0.07 * Math.sin(w), 1.02 + 0.1 * Math.cos(w) + floor, 0.3];
  const knee: Vec3 = [0.2, 0.5 + floor, 0.28];
  return {
    floor,
    feet: [[0.12, floor, 0.05], [-0.12, floor, 0.05]],
    feetRotation: [0, 0, 0, 1],
    hipsRotation: yaw(8 * deg * Math.sin(0.5 * t)),
    hips: [0, 0.74 + floor - 0.3 * reach, -0.05 - 0.1 * reach],
    hands: [lerp(circle, knee, reach), lerp(rightHold, [crate[0], crate[1] + 0.02, crate[2]], reach)],
    look: [0.9 * Math.sin(0.6 * t), 1.25 + 0.25 * Math.sin(1.1 * t), 1.6],
    crate,
    reach,
  };
}
