// Page-side measurements over the wasm core: the benchmark's cases (chain, seeded targets, budgets,
// tolerance 1e-5 L, every solve from the rest pose), timed with performance.now() around the calls
// into the module, so the figures include what a page pays to call the core.
import type { IKCore } from './ikchain.js';
import { SolverKind } from './ikchain.js';

export const REL_TOLERANCE = 1e-5;

export interface Cell {
  solver: SolverKind;
  joints: number;
  trials: number;
  usPerSolve: number; // median over batches of batch time / batch size
  usPerIteration: number; // batch time over the batch's iterations, median over batches
  medianIterations: number;
  successRate: number; // tip within 1e-5 L
}

const median = (v: number[]) => {
  const s = [...v].sort((a, b) => a - b);
  const m = s.length >> 1;
  return s.length % 2 ? s[m] : 0.5 * (s[m - 1] + s[m]);
};

// Solves `trials` seeded targets once untimed (warm-up: the engine tiers up the wasm code), then
// `rounds` timed passes over them in batches of `batch` solves.
export function measureCell(core: IKCore, solver: SolverKind, joints: number, trials: number,
                            rounds = 1, batch = trials): Cell {
  const chain = core.createBenchChain(joints);
  const tolerance = REL_TOLERANCE * chain.totalLength;
  chain.setOptions({ warmStart: false, positionTolerance: tolerance, maxIterations: core.benchMaxIterations(solver) });
  const targets = core.benchTargets(joints, trials);
  chain.setGoals([{ kind: 'position', target: targets[0] }]);
  for (const t of targets) {
    chain.setGoalPosition(0, t);
    chain.solveFast(solver);
  }
  const batchUs: number[] = [];
  const batchUsPerIteration: number[] = [];
  const iterations: number[] = [];
  let successes = 0;
  for (let r = 0; r < rounds; ++r) {
    for (let b = 0; b < targets.length; b += batch) {
      const end = Math.min(targets.length, b + batch);
      let its = 0;
      const t0 = performance.now();
      for (let i = b; i < end; ++i) {
        chain.setGoalPosition(0, targets[i]);
        chain.solveFast(solver);
        its += chain.lastIterations;
      }
      const us = (performance.now() - t0) * 1000;
      batchUs.push(us / (end - b));
      if (its > 0) batchUsPerIteration.push(us / its);
    }
  }
  // Iterations and success, untimed (reading the result object costs more than a solve).
  for (const t of targets) {
    chain.setGoalPosition(0, t);
    chain.solveFast(solver);
    iterations.push(chain.lastIterations);
    if (chain.lastFinalError <= tolerance) successes++;
  }
  chain.dispose();
  return {
    solver, joints, trials,
    usPerSolve: median(batchUs),
    usPerIteration: batchUsPerIteration.length ? median(batchUsPerIteration) : NaN,
    medianIterations: median(iterations),
    successRate: successes / targets.length,
  };
}
