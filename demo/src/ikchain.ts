// A small typed wrapper over the WebAssembly core (src/wasm/ in the repository root). Every solve,
// forward-kinematics pass and benchmark case runs in the core; this file only shapes arguments
// and results for TypeScript.
import createIKChain from './wasm/ikchain_wasm.mjs';
import type { IKChainModule, RawSolveResult, RawWebChain, RawWebObject, RawWebTree } from './wasm/ikchain_wasm.mjs';

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

// The options chains and trees share (src/wasm/web_common.hpp, WebOptions).
export interface SolveOptions {
  maxIterations?: number;
  positionTolerance?: number; // m
  orientationTolerance?: number; // rad
  warmStart?: boolean; // start from the current pose (true) or the rest pose
  timeBudgetUsec?: number; // µs of wall clock per solve, restarts included; 0 = none
  // The core's safety cap on a solve's CPU time (µs, 0 = none; the core's default 50 ms): a
  // net, not a budget. Tests that must not depend on the machine's load turn it off.
  timeCapUsec?: number;
}

const SOLVE_OPTION_DEFAULTS: Required<SolveOptions> = {
  maxIterations: 100, positionTolerance: 1e-5, orientationTolerance: 1e-4, warmStart: true, timeBudgetUsec: 0,
  timeCapUsec: 50_000,
};

export interface Options extends SolveOptions {
  maxStepAngle?: number; // rad per iteration and joint, 0 = no cap
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
const INT = [-(2 ** 31), 2 ** 31 - 1] as const;
type IntegerRanges = Readonly<Record<string, readonly [number, number]>>;

function checkIntegerOptions(options: object, ranges: IntegerRanges): void {
  for (const [name, [min, max]] of Object.entries(ranges)) {
    const v = (options as Record<string, unknown>)[name];
    if (v !== undefined && !(Number.isInteger(v) && (v as number) >= min && (v as number) <= max))
      throw new IKError(`setOptions: ${name} must be an integer in ${min}..${max}, got ${v}`);
  }
}

// The raw objects' add*Goal take the same numbers; a tree's take its level after them (`extra`).
interface GoalAdder<E extends number[]> {
  addPositionGoal(x: number, y: number, z: number, effector: number, weight: number, ...extra: E): string;
  addOrientationGoal(qx: number, qy: number, qz: number, qw: number, effector: number, weight: number,
                     ...extra: E): string;
  addAimGoal(ax: number, ay: number, az: number, dx: number, dy: number, dz: number, effector: number,
             weight: number, ...extra: E): string;
}

function addGoal<E extends number[]>(raw: GoalAdder<E>, g: Goal, effector: number, ...extra: E): string {
  const weight = g.weight ?? 1;
  if (g.kind === 'position') return raw.addPositionGoal(g.target[0], g.target[1], g.target[2], effector, weight, ...extra);
  if (g.kind === 'orientation') {
    const q = g.quaternion;
    return raw.addOrientationGoal(q[0], q[1], q[2], q[3], effector, weight, ...extra);
  }
  return raw.addAimGoal(g.axis[0], g.axis[1], g.axis[2], g.direction[0], g.direction[1], g.direction[2], effector,
                        weight, ...extra);
}

function summaryOf(r: RawSolveResult): SolveResult {
  return {
    reason: r.reason as TerminationReason, usable: r.usable, iterations: r.iterations,
    initialError: r.initialError, finalError: r.finalError, finalPositionError: r.finalPositionError,
    finalOrientationError: r.finalOrientationError, elapsedUs: r.elapsedUs, budgetExhausted: r.budgetExhausted,
    restarts: r.restarts, escapes: r.escapes, message: r.message,
  };
}

// The raw object when `message` (its build's) is empty; else it is freed and IKError names `what`.
function built<R extends RawWebObject>(raw: R, message: string, what: string): R {
  if (message !== '') {
    raw.delete();
    throw new IKError(`${what}: ${message}`);
  }
  return raw;
}

// What Chain and Tree share over their raw objects (src/wasm/web_common.hpp on the C++ side).
abstract class CoreObject<R extends RawWebObject> {
  protected readonly raw: R;

  constructor(raw: R) { this.raw = raw; }

  get jointCount(): number { return this.raw.jointCount(); }
  get dofCount(): number { return this.raw.dofCount(); }
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

  protected applySolveOptions(o: Required<SolveOptions>): void {
    this.raw.setMaxIterations(o.maxIterations);
    this.raw.setTolerances(o.positionTolerance, o.orientationTolerance);
    this.raw.setWarmStart(o.warmStart);
    this.raw.setTimeBudgetUsec(o.timeBudgetUsec);
    this.raw.setTimeCapUsec(o.timeCapUsec);
  }

  // A solve without building a result object (timing loops, per frame); returns the reason.
  solveFast(kind: SolverKind = SolverKind.DLS): TerminationReason {
    return REASONS[this.raw.solve(kind)] ?? 'invalid_input';
  }
  get lastIterations(): number { return this.raw.lastIterations(); }
  get lastFinalError(): number { return this.raw.lastFinalError(); }

  params(): Float64Array { return this.raw.params(); }
  setParams(values: ArrayLike<number>): void { check(this.raw.setParams(Array.from(values)), 'setParams'); }
  resetPose(): void { this.raw.resetPose(); }

  // The joint frames at the start of the raw frames (forward kinematics in the core), base space.
  protected jointFrames(f: Float64Array): JointFrame[] {
    const joints: JointFrame[] = [];
    for (let i = 0, n = this.raw.jointCount(); i < n; ++i) {
      const o = 7 * i;
      joints.push({ position: [f[o], f[o + 1], f[o + 2]], quaternion: [f[o + 3], f[o + 4], f[o + 5], f[o + 6]] });
    }
    return joints;
  }

  // Frees the core object (embind objects are not garbage-collected).
  dispose(): void { this.raw.delete(); }
}

const CHAIN_INTEGER_OPTIONS: IntegerRanges = {
  maxIterations: INT, maxRestarts: INT, restartSeed: [0, 2 ** 32 - 1], // int, int, unsigned
};

export class Chain extends CoreObject<RawWebChain> {
  private opts: Required<Options> = {
    ...SOLVE_OPTION_DEFAULTS, maxStepAngle: 0, maxRestarts: 0, restartSeed: 1,
  };

  // Use IKCore.createChain / createBenchChain.
  constructor(raw: RawWebChain) {
    super(raw);
    this.applyOptions();
  }

  get totalLength(): number { return this.raw.totalLength(); }
  get options(): Readonly<Required<Options>> { return this.opts; }

  // Replaces every goal. Throws IKError naming the goal when one is refused.
  setGoals(goals: readonly Goal[]): void {
    this.raw.clearGoals();
    goals.forEach((g, i) => check(addGoal(this.raw, g, g.effector ?? 0), `goal ${i}`));
  }

  // Throws IKError (options unchanged) for an integer option that is not one; every other check is
  // the core's, at the next solve.
  setOptions(options: Options): void {
    checkIntegerOptions(options, CHAIN_INTEGER_OPTIONS);
    this.opts = { ...this.opts, ...options };
    this.applyOptions();
  }

  private applyOptions(): void {
    const o = this.opts;
    this.applySolveOptions(o);
    this.raw.setMaxStepAngle(o.maxStepAngle);
    this.raw.setMaxRestarts(o.maxRestarts);
    this.raw.setRestartSeed(o.restartSeed);
  }

  // One solve; the core validates everything and names a bad field in result.message.
  solve(kind: SolverKind): SolveResult {
    this.raw.solve(kind);
    return this.result();
  }

  result(): SolveResult { return summaryOf(this.raw.result()); }

  // Joint frames of the current pose (forward kinematics in the core), base space.
  frames(): Frames {
    const f = this.raw.frames();
    const n = this.raw.jointCount();
    return { joints: this.jointFrames(f), tip: [f[7 * n], f[7 * n + 1], f[7 * n + 2]] };
  }
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

export interface TreeOptions extends SolveOptions {
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

const TREE_INTEGER_OPTIONS: IntegerRanges = { maxIterations: INT, postureIterations: INT };

export class Tree extends CoreObject<RawWebTree> {
  readonly spec: TreeSpec;
  private opts: Required<TreeOptions> = { ...SOLVE_OPTION_DEFAULTS, postureIterations: 0 };
  private errors = new Float64Array(0);

  // Use IKCore.createTree.
  constructor(raw: RawWebTree, spec: TreeSpec) {
    super(raw);
    this.spec = spec;
    this.applyOptions();
  }

  get effectorCount(): number { return this.raw.effectorCount(); }
  get options(): Readonly<Required<TreeOptions>> { return this.opts; }

  // Replaces every goal. Throws IKError naming the goal when one is refused; the effector and the
  // level are checked by the core at the next solve (reason invalid_input, the message names them).
  setGoals(goals: readonly TreeGoal[]): void {
    this.raw.clearGoals();
    goals.forEach((g, i) => check(addGoal(this.raw, g, g.effector, g.level), `goal ${i}`));
    this.errors = new Float64Array(goals.length);
  }

  // The posture below every level: preferred params (dofCount values) and one stiffness in [0, 1].
  setPosture(values: ArrayLike<number>, stiffness: number): void {
    check(this.raw.setPosture(Array.from(values), stiffness), 'setPosture');
  }
  clearPosture(): void { this.raw.clearPosture(); }

  setOptions(options: TreeOptions): void {
    checkIntegerOptions(options, TREE_INTEGER_OPTIONS);
    this.opts = { ...this.opts, ...options };
    this.applyOptions();
  }

  private applyOptions(): void {
    this.applySolveOptions(this.opts);
    this.raw.setPostureIterations(this.opts.postureIterations);
  }

  solve(kind: SolverKind = SolverKind.DLS): TreeSolveResult {
    this.raw.solve(kind);
    return this.result();
  }
  get lastElapsedUs(): number { return this.raw.lastElapsedUs(); }
  // The last solve's per-goal errors, in setGoals' order (a view reused between calls).
  goalErrors(): Float64Array {
    this.raw.goalErrorsInto(this.errors);
    return this.errors;
  }

  result(): TreeSolveResult {
    const r = this.raw.result();
    return { ...summaryOf(r), goalErrors: Array.from(r.goalErrors), levelMet: [...r.levelMet] };
  }

  // Joint frames and effector positions of the current pose (forward kinematics in the core).
  framesArray(): Float64Array { return this.raw.frames(); }
  frames(): TreeFrames {
    const f = this.raw.frames();
    const effectors: [number, number, number][] = [];
    for (let o = 7 * this.raw.jointCount(); o + 2 < f.length; o += 3) effectors.push([f[o], f[o + 1], f[o + 2]]);
    return { joints: this.jointFrames(f), effectors };
  }
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
    return new Chain(built(raw, raw.build(), 'chain'));
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
    return new Tree(built(raw, raw.build(), 'tree'), spec);
  }

  createArm(spec: ArmSpec): Chain {
    const { joints, tip } = armJoints(spec);
    return this.createChain(joints, tip);
  }

  // The benchmark's chain (bench/core_bench.cpp): n hinges alternating z/y, unit links.
  createBenchChain(joints: number, planar = false): Chain {
    const raw = new this.module.WebChain();
    return new Chain(built(raw, raw.buildBenchChain(joints, planar), 'bench chain'));
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
