// A small typed wrapper over the WebAssembly core (src/wasm/ in the repository root). Every solve,
// forward-kinematics pass and benchmark case runs in the core; this file only shapes arguments
// and results for TypeScript.
import createIKChain from './wasm/ikchain_wasm.mjs';
import type { IKChainModule, RawWebChain, RawWebTree } from './wasm/ikchain_wasm.mjs';

export type Vec3 = readonly [number, number, number];
export type Quat = readonly [number, number, number, number]; // x, y, z, w

// Codes as in ikchain/options.hpp (SolverKind).
export enum SolverKind {
  TwoBone = 0,
  CCD = 1,
  JacobianPinv = 2,
  DLS = 3,
  BFGS = 4,
  FABRIK = 5,
}

export const SOLVERS: readonly { kind: SolverKind; id: string; label: string }[] = [
  { kind: SolverKind.DLS, id: 'dls', label: 'Damped least squares' },
  { kind: SolverKind.BFGS, id: 'bfgs', label: 'BFGS' },
  { kind: SolverKind.JacobianPinv, id: 'jacobian_pinv', label: 'Jacobian pseudo-inverse' },
  { kind: SolverKind.CCD, id: 'ccd', label: 'CCD' },
  { kind: SolverKind.FABRIK, id: 'fabrik', label: 'FABRIK' },
  { kind: SolverKind.TwoBone, id: 'two_bone', label: 'Two bone (2 joints)' },
];

export type TerminationReason = 'converged' | 'max_iterations' | 'stalled' | 'unreachable' | 'invalid_input';
// Codes as in ikchain/result.hpp (TerminationReason).
export const REASONS: readonly TerminationReason[] = [
  'converged', 'max_iterations', 'stalled', 'unreachable', 'invalid_input',
];

export interface SolveResult {
  reason: TerminationReason;
  usable: boolean;
  iterations: number;
  initialError: number;
  finalError: number;
  finalPositionError: number;
  finalOrientationError: number;
  elapsedUs: number; // measured inside the core
  // The time budget (Options.timeBudgetUsec) ran out: reason is then max_iterations (or unreachable
  // when the pose it stopped at is provably a best reach).
  budgetExhausted: boolean;
  restarts: number; // restarts run (Options.maxRestarts); iterations include theirs
  escapes: number; // escapes from stuck poses inside the runs, restarts' included
  message: string; // why, for invalid_input
}

export type JointSpec =
  | { type: 'hinge'; offset: Vec3; axis: Vec3; limits?: { min: number; max: number } }
  | { type: 'ball'; offset: Vec3; limits?: { cone: number; twistMin: number; twistMax: number } };

// The demo arm: n joints of one type, links along +Y, total reach `reach`. Hinges: the first turns
// about Y (a base yaw), then alternately about Z and X. Limits: hinges ±100° (the yaw ±170°),
// balls a 70° cone and ±30° twist.
export interface ArmSpec {
  joints: number;
  jointType: 'hinge' | 'ball';
  limits: boolean;
  reach?: number;
}

export function armJoints(spec: ArmSpec): { joints: JointSpec[]; tip: Vec3 } {
  if (!Number.isInteger(spec.joints) || spec.joints < 1 || spec.joints > 200)
    throw new IKError(`joints must be an integer in 1..200, got ${spec.joints}`);
  const link = (spec.reach ?? 4) / spec.joints;
  const deg = Math.PI / 180;
  const joints: JointSpec[] = [];
  for (let i = 0; i < spec.joints; ++i) {
    const offset: Vec3 = i === 0 ? [0, 0, 0] : [0, link, 0];
    if (spec.jointType === 'ball') {
      joints.push({ type: 'ball', offset, limits: spec.limits ? { cone: 70 * deg, twistMin: -30 * deg, twistMax: 30 * deg } : undefined });
    } else {
      const axis: Vec3 = i === 0 ? [0, 1, 0] : i % 2 === 1 ? [0, 0, 1] : [1, 0, 0];
      const range = (i === 0 ? 170 : 100) * deg;
      joints.push({ type: 'hinge', offset, axis, limits: spec.limits ? { min: -range, max: range } : undefined });
    }
  }
  return { joints, tip: [0, link, 0] };
}

export type Goal =
  | { kind: 'position'; target: Vec3; effector?: number; weight?: number }
  | { kind: 'orientation'; quaternion: Quat; effector?: number; weight?: number }
  | { kind: 'aim'; axis: Vec3; direction: Vec3; effector?: number; weight?: number };

export interface Options {
  maxIterations?: number;
  positionTolerance?: number; // m
  orientationTolerance?: number; // rad
  warmStart?: boolean; // start from the current pose (true) or the rest pose
  maxStepAngle?: number; // rad per iteration and joint, 0 = no cap
  timeBudgetUsec?: number; // µs of wall clock per solve, restarts included; 0 = none
  // The core's safety cap on a solve's wall-clock time (µs, 0 = none; the core's default 50 ms): a
  // net, not a budget. Tests that must not depend on the machine's load turn it off.
  timeCapUsec?: number;
  // Restarts from seeded random in-limit poses while the goals are unmet and not provably out of
  // reach (off by default: a restart may jump to another branch between frames); the best pose of
  // all runs is kept. The same seed gives the same restarts, so the same result.
  maxRestarts?: number;
  restartSeed?: number; // an integer in 0..2^32-1
}

export interface JointFrame {
  position: [number, number, number];
  quaternion: [number, number, number, number]; // x, y, z, w
}

export interface Frames {
  joints: JointFrame[];
  tip: [number, number, number];
}

export class IKError extends Error {}

function check(message: string, what: string): void {
  if (message !== '') throw new IKError(`${what}: ${message}`);
}

// The core validates every option's range and names a bad one in the solve's result; an integer
// option must first survive the crossing into C++, where embind would silently truncate or wrap it.
const INTEGER_OPTIONS = {
  maxIterations: [-(2 ** 31), 2 ** 31 - 1], // int
  maxRestarts: [-(2 ** 31), 2 ** 31 - 1], // int
  restartSeed: [0, 2 ** 32 - 1], // unsigned
} as const;

function checkIntegerOptions(options: Options): void {
  for (const [name, [min, max]] of Object.entries(INTEGER_OPTIONS)) {
    const v = options[name as keyof typeof INTEGER_OPTIONS];
    if (v !== undefined && !(Number.isInteger(v) && v >= min && v <= max))
      throw new IKError(`setOptions: ${name} must be an integer in ${min}..${max}, got ${v}`);
  }
}

export class Chain {
  private readonly raw: RawWebChain;
  private opts: Required<Options> = {
    maxIterations: 100, positionTolerance: 1e-5, orientationTolerance: 1e-4, warmStart: true, maxStepAngle: 0,
    timeBudgetUsec: 0, timeCapUsec: 50_000, maxRestarts: 0, restartSeed: 1,
  };

  // Use IKCore.createChain / createBenchChain.
  constructor(raw: RawWebChain) {
    this.raw = raw;
    this.applyOptions();
  }

  get jointCount(): number { return this.raw.jointCount(); }
  get dofCount(): number { return this.raw.dofCount(); }
  get totalLength(): number { return this.raw.totalLength(); }
  get options(): Readonly<Required<Options>> { return this.opts; }

  // Replaces every goal. Throws IKError naming the goal when one is refused.
  setGoals(goals: readonly Goal[]): void {
    this.raw.clearGoals();
    goals.forEach((g, i) => {
      const effector = g.effector ?? 0;
      const weight = g.weight ?? 1;
      let message: string;
      if (g.kind === 'position') {
        message = this.raw.addPositionGoal(g.target[0], g.target[1], g.target[2], effector, weight);
      } else if (g.kind === 'orientation') {
        const q = g.quaternion;
        message = this.raw.addOrientationGoal(q[0], q[1], q[2], q[3], effector, weight);
      } else {
        message = this.raw.addAimGoal(g.axis[0], g.axis[1], g.axis[2], g.direction[0], g.direction[1],
                                      g.direction[2], effector, weight);
      }
      check(message, `goal ${i}`);
    });
  }

  get goalCount(): number { return this.raw.goalCount(); }

  // Per-frame updates that allocate nothing in the core. Throw when goal `index` is of another kind.
  setGoalPosition(index: number, p: Vec3): void {
    if (!this.raw.setGoalPosition(index, p[0], p[1], p[2]))
      throw new IKError(`setGoalPosition: goal ${index} is not a position goal`);
  }
  setGoalOrientation(index: number, q: Quat): void {
    if (!this.raw.setGoalOrientation(index, q[0], q[1], q[2], q[3]))
      throw new IKError(`setGoalOrientation: goal ${index} is not an orientation goal`);
  }
  setAimDirection(index: number, d: Vec3): void {
    if (!this.raw.setGoalAimDirection(index, d[0], d[1], d[2]))
      throw new IKError(`setAimDirection: goal ${index} is not an aim goal`);
  }

  // Throws IKError (options unchanged) for an integer option that is not one; every other check is
  // the core's, at the next solve.
  setOptions(options: Options): void {
    checkIntegerOptions(options);
    this.opts = { ...this.opts, ...options };
    this.applyOptions();
  }

  private applyOptions(): void {
    const o = this.opts;
    this.raw.setMaxIterations(o.maxIterations);
    this.raw.setTolerances(o.positionTolerance, o.orientationTolerance);
    this.raw.setWarmStart(o.warmStart);
    this.raw.setMaxStepAngle(o.maxStepAngle);
    this.raw.setTimeBudgetUsec(o.timeBudgetUsec);
    this.raw.setTimeCapUsec(o.timeCapUsec);
    this.raw.setMaxRestarts(o.maxRestarts);
    this.raw.setRestartSeed(o.restartSeed);
  }

  // One solve; the core validates everything and names a bad field in result.message.
  solve(kind: SolverKind): SolveResult {
    this.raw.solve(kind);
    return this.result();
  }

  // The same solve without building a result object (timing loops); returns the reason.
  solveFast(kind: SolverKind): TerminationReason {
    return REASONS[this.raw.solve(kind)] ?? 'invalid_input';
  }
  get lastIterations(): number { return this.raw.lastIterations(); }
  get lastFinalError(): number { return this.raw.lastFinalError(); }

  result(): SolveResult {
    const r = this.raw.result();
    return {
      reason: r.reason as TerminationReason,
      usable: r.usable,
      iterations: r.iterations,
      initialError: r.initialError,
      finalError: r.finalError,
      finalPositionError: r.finalPositionError,
      finalOrientationError: r.finalOrientationError,
      elapsedUs: r.elapsedUs,
      budgetExhausted: r.budgetExhausted,
      restarts: r.restarts,
      escapes: r.escapes,
      message: r.message,
    };
  }

  params(): Float64Array { return this.raw.params(); }
  setParams(values: ArrayLike<number>): void { check(this.raw.setParams(Array.from(values)), 'setParams'); }
  resetPose(): void { this.raw.resetPose(); }

  // Joint frames of the current pose (forward kinematics in the core), base space.
  frames(): Frames {
    const f = this.raw.frames();
    const n = this.raw.jointCount();
    const joints: JointFrame[] = [];
    for (let i = 0; i < n; ++i) {
      const o = 7 * i;
      joints.push({ position: [f[o], f[o + 1], f[o + 2]], quaternion: [f[o + 3], f[o + 4], f[o + 5], f[o + 6]] });
    }
    return { joints, tip: [f[7 * n], f[7 * n + 1], f[7 * n + 2]] };
  }

  // Frees the core object (embind objects are not garbage-collected).
  dispose(): void { this.raw.delete(); }
}


// --- Trees (whole bodies): ikchain/tree.hpp, ikchain/tree_solve.hpp through src/wasm/web_tree.hpp.

// A joint of a tree: `parent` is an earlier joint's index (-1: the base); the offset is from the
// parent's frame, the rest rotation identity. Ball limits: a cone about `twistAxis` (the bone's
// direction in joint space) and a twist range about it. motionCost: how reluctantly the solver
// moves it (1 = as any joint).
export type TreeJointSpec =
  | { name: string; type: 'ball'; parent: number; offset: Vec3; motionCost?: number;
      limits?: { cone: number; twistMin: number; twistMax: number; twistAxis: Vec3 } }
  | { name: string; type: 'hinge'; parent: number; offset: Vec3; axis: Vec3; motionCost?: number;
      limits?: { min: number; max: number } };

export interface TreeSpec {
  joints: readonly TreeJointSpec[];
  effectors: readonly { name: string; joint: number; offset: Vec3 }[];
  // Joint 0 (a ball with parent -1) also translates: 3 more params first (m, base space).
  floatingRoot?: boolean;
  translationMotionCost?: number;
}

// A goal on a tree effector at a priority level (1 = highest, up to 4).
export type TreeGoal = Goal & { effector: number; level: number };

export interface TreeOptions {
  maxIterations?: number;
  positionTolerance?: number; // m
  orientationTolerance?: number; // rad
  warmStart?: boolean;
  timeBudgetUsec?: number;
  timeCapUsec?: number; // as Options.timeCapUsec
  // With a posture: once every goal is met, stop after this many more iterations (0 = until it settles).
  postureIterations?: number;
}

export interface TreeSolveResult extends SolveResult {
  goalErrors: number[]; // per goal, in setGoals' order: m for position goals, rad otherwise
  levelMet: boolean[]; // per level 1..4 (index level - 1)
}

export interface TreeFrames {
  joints: JointFrame[];
  effectors: [number, number, number][];
}

const INTEGER_TREE_OPTIONS = ['maxIterations', 'postureIterations'] as const;

export class Tree {
  private readonly raw: RawWebTree;
  readonly spec: TreeSpec;
  private opts: Required<TreeOptions> = {
    maxIterations: 100, positionTolerance: 1e-5, orientationTolerance: 1e-4, warmStart: true, timeBudgetUsec: 0,
    timeCapUsec: 50_000, postureIterations: 0,
  };
  private errors = new Float64Array(0);

  // Use IKCore.createTree.
  constructor(raw: RawWebTree, spec: TreeSpec) {
    this.raw = raw;
    this.spec = spec;
    this.applyOptions();
  }

  get jointCount(): number { return this.raw.jointCount(); }
  get dofCount(): number { return this.raw.dofCount(); }
  get effectorCount(): number { return this.raw.effectorCount(); }
  get options(): Readonly<Required<TreeOptions>> { return this.opts; }
  get goalCount(): number { return this.raw.goalCount(); }

  // Replaces every goal. Throws IKError naming the goal when one is refused; the effector and the
  // level are checked by the core at the next solve (reason invalid_input, the message names them).
  setGoals(goals: readonly TreeGoal[]): void {
    this.raw.clearGoals();
    goals.forEach((g, i) => {
      const w = g.weight ?? 1;
      let message: string;
      if (g.kind === 'position') {
        message = this.raw.addPositionGoal(g.target[0], g.target[1], g.target[2], g.effector, w, g.level);
      } else if (g.kind === 'orientation') {
        const q = g.quaternion;
        message = this.raw.addOrientationGoal(q[0], q[1], q[2], q[3], g.effector, w, g.level);
      } else {
        message = this.raw.addAimGoal(g.axis[0], g.axis[1], g.axis[2], g.direction[0], g.direction[1], g.direction[2],
                                      g.effector, w, g.level);
      }
      check(message, `goal ${i}`);
    });
    this.errors = new Float64Array(goals.length);
  }

  // Per-frame updates that allocate nothing in the core. Throw when goal `index` is of another kind.
  setGoalPosition(index: number, p: Vec3): void {
    if (!this.raw.setGoalPosition(index, p[0], p[1], p[2]))
      throw new IKError(`setGoalPosition: goal ${index} is not a position goal`);
  }
  setGoalOrientation(index: number, q: Quat): void {
    if (!this.raw.setGoalOrientation(index, q[0], q[1], q[2], q[3]))
      throw new IKError(`setGoalOrientation: goal ${index} is not an orientation goal`);
  }
  setAimDirection(index: number, d: Vec3): void {
    if (!this.raw.setGoalAimDirection(index, d[0], d[1], d[2]))
      throw new IKError(`setAimDirection: goal ${index} is not an aim goal`);
  }

  // The posture below every level: preferred params (dofCount values) and one stiffness in [0, 1].
  setPosture(values: ArrayLike<number>, stiffness: number): void {
    check(this.raw.setPosture(Array.from(values), stiffness), 'setPosture');
  }
  clearPosture(): void { this.raw.clearPosture(); }

  setOptions(options: TreeOptions): void {
    for (const name of INTEGER_TREE_OPTIONS) {
      const v = options[name];
      if (v !== undefined && !(Number.isInteger(v) && v >= -(2 ** 31) && v <= 2 ** 31 - 1))
        throw new IKError(`setOptions: ${name} must be an integer, got ${v}`);
    }
    this.opts = { ...this.opts, ...options };
    this.applyOptions();
  }

  private applyOptions(): void {
    const o = this.opts;
    this.raw.setMaxIterations(o.maxIterations);
    this.raw.setTolerances(o.positionTolerance, o.orientationTolerance);
    this.raw.setWarmStart(o.warmStart);
    this.raw.setTimeBudgetUsec(o.timeBudgetUsec);
    this.raw.setTimeCapUsec(o.timeCapUsec);
    this.raw.setPostureIterations(o.postureIterations);
  }

  solve(kind: SolverKind = SolverKind.DLS): TreeSolveResult {
    this.raw.solve(kind);
    return this.result();
  }
  // The same solve without building a result object (per frame); returns the reason.
  solveFast(kind: SolverKind = SolverKind.DLS): TerminationReason {
    return REASONS[this.raw.solve(kind)] ?? 'invalid_input';
  }
  get lastIterations(): number { return this.raw.lastIterations(); }
  get lastElapsedUs(): number { return this.raw.lastElapsedUs(); }
  get lastFinalError(): number { return this.raw.lastFinalError(); }
  // The last solve's per-goal errors, in setGoals' order (a view reused between calls).
  goalErrors(): Float64Array {
    this.raw.goalErrorsInto(this.errors);
    return this.errors;
  }

  result(): TreeSolveResult {
    const r = this.raw.result();
    return {
      reason: r.reason as TerminationReason, usable: r.usable, iterations: r.iterations,
      initialError: r.initialError, finalError: r.finalError, finalPositionError: r.finalPositionError,
      finalOrientationError: r.finalOrientationError, elapsedUs: r.elapsedUs, budgetExhausted: r.budgetExhausted,
      restarts: r.restarts, escapes: r.escapes, message: r.message,
      goalErrors: Array.from(r.goalErrors), levelMet: [...r.levelMet],
    };
  }

  params(): Float64Array { return this.raw.params(); }
  setParams(values: ArrayLike<number>): void { check(this.raw.setParams(Array.from(values)), 'setParams'); }
  resetPose(): void { this.raw.resetPose(); }

  // Joint frames and effector positions of the current pose (forward kinematics in the core).
  framesArray(): Float64Array { return this.raw.frames(); }
  frames(): TreeFrames {
    const f = this.raw.frames();
    const n = this.raw.jointCount();
    const joints: JointFrame[] = [];
    for (let i = 0; i < n; ++i) {
      const o = 7 * i;
      joints.push({ position: [f[o], f[o + 1], f[o + 2]], quaternion: [f[o + 3], f[o + 4], f[o + 5], f[o + 6]] });
    }
    const effectors: [number, number, number][] = [];
    for (let e = 0, o = 7 * n; o + 2 < f.length; ++e, o += 3) effectors.push([f[o], f[o + 1], f[o + 2]]);
    return { joints, effectors };
  }

  dispose(): void { this.raw.delete(); }
}

export interface ConvergenceTrace {
  errors: number[]; // errors[k]: tip distance after a budget of k iterations (k = 0: the rest pose)
  stopped: string;
  tolerance: number;
}

export interface PrecisionRun {
  distance: number;
  reason: string;
  iterations: number;
}

export class IKCore {
  private readonly module: IKChainModule;
  constructor(module: IKChainModule) { this.module = module; }

  createChain(joints: readonly JointSpec[], tip: Vec3): Chain {
    const raw = new this.module.WebChain();
    for (const j of joints) {
      if (j.type === 'hinge') {
        raw.addHinge(j.offset[0], j.offset[1], j.offset[2], j.axis[0], j.axis[1], j.axis[2], !!j.limits,
                     j.limits?.min ?? 0, j.limits?.max ?? 0);
      } else {
        raw.addBall(j.offset[0], j.offset[1], j.offset[2], !!j.limits, j.limits?.cone ?? 0,
                    j.limits?.twistMin ?? 0, j.limits?.twistMax ?? 0);
      }
    }
    raw.setTip(tip[0], tip[1], tip[2]);
    const message = raw.build();
    if (message !== '') {
      raw.delete();
      throw new IKError(`chain: ${message}`);
    }
    return new Chain(raw);
  }

  // A tree from its joints and effectors; throws IKError with the core's message (naming the joint
  // or effector) when it does not build.
  createTree(spec: TreeSpec): Tree {
    const raw = new this.module.WebTree();
    for (const j of spec.joints) {
      const o = j.offset;
      if (j.type === 'ball') {
        const l = j.limits;
        const a = l?.twistAxis ?? [0, 1, 0];
        raw.addBall(j.parent, o[0], o[1], o[2], !!l, l?.cone ?? 0, l?.twistMin ?? 0, l?.twistMax ?? 0, a[0], a[1], a[2],
                    j.motionCost ?? 1);
      } else {
        raw.addHinge(j.parent, o[0], o[1], o[2], j.axis[0], j.axis[1], j.axis[2], !!j.limits, j.limits?.min ?? 0,
                     j.limits?.max ?? 0, j.motionCost ?? 1);
      }
    }
    for (const e of spec.effectors) raw.addEffector(e.joint, e.offset[0], e.offset[1], e.offset[2]);
    raw.setFloatingRoot(!!spec.floatingRoot, spec.translationMotionCost ?? 1);
    const message = raw.build();
    if (message !== '') {
      raw.delete();
      throw new IKError(`tree: ${message}`);
    }
    return new Tree(raw, spec);
  }

  createArm(spec: ArmSpec): Chain {
    const { joints, tip } = armJoints(spec);
    return this.createChain(joints, tip);
  }

  // The benchmark's chain (bench/core_bench.cpp): n hinges alternating z/y, unit links.
  createBenchChain(joints: number, planar = false): Chain {
    const raw = new this.module.WebChain();
    const message = raw.buildBenchChain(joints, planar);
    if (message !== '') {
      raw.delete();
      throw new IKError(`bench chain: ${message}`);
    }
    return new Chain(raw);
  }

  // The benchmark's budgets and seeded reachable targets (the bench seeds an n-joint cell with 1000 + n).
  benchMaxIterations(kind: SolverKind): number { return this.module.benchMaxIterations(kind); }
  benchTargets(joints: number, count: number, seed = 1000 + joints): Vec3[] {
    const t = this.module.benchTargets(joints, count, seed);
    const out: Vec3[] = [];
    for (let i = 0; i + 2 < t.length; i += 3) out.push([t[i], t[i + 1], t[i + 2]]);
    return out;
  }
  convergenceTrace(kind: SolverKind): ConvergenceTrace {
    const t = this.module.convergenceTrace(kind);
    return { errors: Array.from(t.errors), stopped: t.stopped, tolerance: t.tolerance };
  }
  precisionRun(kind: SolverKind, planar: boolean): PrecisionRun {
    return this.module.precisionRun(kind, planar);
  }
}

let loading: Promise<IKCore> | undefined;
export function loadIKCore(): Promise<IKCore> {
  loading ??= createIKChain().then((m) => new IKCore(m));
  return loading;
}
