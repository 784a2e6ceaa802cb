// Types of the embind module built by `scons web` (src/wasm/bindings.cpp). The page uses the
// typed wrapper in ../ikchain.ts, not these directly.
export interface RawSolveResult {
  reason: string;
  usable: boolean;
  iterations: number;
  initialError: number;
  finalError: number;
  initialPositionError: number;
  finalPositionError: number;
  initialOrientationError: number;
  finalOrientationError: number;
  elapsedUs: number;
  budgetExhausted: boolean;
  restarts: number;
  escapes: number;
  message: string;
}

// What both classes have (bindings.cpp, bind_common).
export interface RawWebObject {
  build(): string;
  jointCount(): number;
  dofCount(): number;
  clearGoals(): void;
  goalCount(): number;
  setGoalPosition(index: number, x: number, y: number, z: number): boolean;
  setGoalOrientation(index: number, qx: number, qy: number, qz: number, qw: number): boolean;
  setGoalAimDirection(index: number, x: number, y: number, z: number): boolean;
  setMaxIterations(n: number): void;
  setTolerances(position: number, orientation: number): void;
  setWarmStart(on: boolean): void;
  setTimeBudgetUsec(usec: number): void;
  setTimeCapUsec(usec: number): void;
  solve(kind: number): number;
  resetPose(): void;
  lastIterations(): number;
  lastFinalError(): number;
  params(): Float64Array;
  setParams(values: ArrayLike<number>): string;
  frames(): Float64Array;
  delete(): void;
}

export interface RawWebChain extends RawWebObject {
  clearJoints(): void;
  addHinge(ox: number, oy: number, oz: number, ax: number, ay: number, az: number, limited: boolean,
           min: number, max: number): void;
  addBall(ox: number, oy: number, oz: number, limited: boolean, cone: number, twistMin: number,
          twistMax: number): void;
  setTip(x: number, y: number, z: number): void;
  buildBenchChain(joints: number, planar: boolean): string;
  totalLength(): number;
  addPositionGoal(x: number, y: number, z: number, effector: number, weight: number): string;
  addOrientationGoal(qx: number, qy: number, qz: number, qw: number, effector: number, weight: number): string;
  addAimGoal(ax: number, ay: number, az: number, dx: number, dy: number, dz: number, effector: number,
             weight: number): string;
  setMaxStepAngle(radians: number): void;
  setMaxRestarts(n: number): void;
  setRestartSeed(seed: number): void;
  result(): RawSolveResult;
}

export interface RawTreeResult extends RawSolveResult {
  goalErrors: Float64Array;
  levelMet: boolean[];
}

export interface RawWebTree extends RawWebObject {
  clear(): void;
  addBall(parent: number, ox: number, oy: number, oz: number, limited: boolean, cone: number, twistMin: number,
          twistMax: number, tx: number, ty: number, tz: number, motionCost: number): number;
  addHinge(parent: number, ox: number, oy: number, oz: number, ax: number, ay: number, az: number, limited: boolean,
           min: number, max: number, motionCost: number): number;
  addEffector(joint: number, ox: number, oy: number, oz: number): number;
  setFloatingRoot(on: boolean, translationMotionCost: number): void;
  effectorCount(): number;
  addPositionGoal(x: number, y: number, z: number, effector: number, weight: number, level: number): string;
  addOrientationGoal(qx: number, qy: number, qz: number, qw: number, effector: number, weight: number,
                     level: number): string;
  addAimGoal(ax: number, ay: number, az: number, dx: number, dy: number, dz: number, effector: number,
             weight: number, level: number): string;
  setPosture(values: ArrayLike<number>, stiffness: number): string;
  clearPosture(): void;
  setPostureIterations(n: number): void;
  result(): RawTreeResult;
  goalErrorsInto(out: Float64Array): void;
  lastElapsedUs(): number;
}

export interface IKChainModule {
  WebChain: new () => RawWebChain;
  WebTree: new () => RawWebTree;
  benchMaxIterations(kind: number): number;
  benchTargets(joints: number, count: number, seed: number): Float64Array;
  convergenceTrace(kind: number): { errors: Float64Array; stopped: string; tolerance: number };
  precisionRun(kind: number, planar: boolean): { distance: number; reason: string; iterations: number };
}

declare function createIKChain(options?: Record<string, unknown>): Promise<IKChainModule>;
export default createIKChain;
