// Arm reach: a chain from the core follows a target the user drags with a transform gizmo.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { TransformControls } from 'three/examples/jsm/controls/TransformControls.js';

import { ChainMesh, basicScene } from './chainMesh.js';
import type { Chain, IKCore, SolveResult } from './ikchain.js';
import { SolverKind } from './ikchain.js';

export interface ArmSettings {
  solver: SolverKind;
  joints: number;
  jointType: 'hinge' | 'ball';
  limits: boolean;
  orientation: boolean;
  restarts: number; // the solve's maxRestarts (0 = off, the core's default)
}

export const ARM_TOLERANCE = 1e-4; // m (and rad for the hand's rotation)

export class ArmView {
  readonly scene: THREE.Scene;
  readonly camera: THREE.PerspectiveCamera;
  readonly orbit: OrbitControls;
  readonly gizmo: TransformControls;
  readonly target = new THREE.Group();
  private chain?: Chain;
  private mesh?: ChainMesh;
  private settings: ArmSettings;
  lastResult?: SolveResult;
  private solveTimesUs: number[] = [];

  constructor(private readonly core: IKCore, dom: HTMLElement, settings: ArmSettings) {
    this.settings = settings;
    this.scene = basicScene().scene;
    this.camera = new THREE.PerspectiveCamera(50, 1, 0.05, 200);
    this.camera.position.set(4.2, 3.6, 5.6);
    this.orbit = new OrbitControls(this.camera, dom);
    this.orbit.target.set(0.6, 1.6, 0);
    this.orbit.update();

    const ball = new THREE.Mesh(new THREE.SphereGeometry(0.09, 16, 12),
                                new THREE.MeshStandardMaterial({ color: 0xf7a24f, emissive: 0x442200 }));
    this.target.add(ball, new THREE.AxesHelper(0.45));
    this.target.position.set(2, 2.2, 1);
    this.scene.add(this.target);
    this.gizmo = new TransformControls(this.camera, dom);
    this.gizmo.attach(this.target);
    this.gizmo.setSize(0.9);
    this.gizmo.addEventListener('dragging-changed', (e) => { this.orbit.enabled = !(e as unknown as { value: boolean }).value; });
    this.scene.add(this.gizmo.getHelper());
    this.rebuild(settings);
  }

  setEnabled(on: boolean): void {
    this.orbit.enabled = on;
    this.gizmo.enabled = on;
  }

  // Rebuilds the chain when its shape changed; solver / orientation changes only set goals.
  rebuild(settings: ArmSettings): void {
    const shapeChanged = !this.chain || settings.joints !== this.settings.joints ||
      settings.jointType !== this.settings.jointType || settings.limits !== this.settings.limits;
    this.settings = settings;
    if (shapeChanged) {
      this.chain?.dispose();
      this.mesh?.dispose();
      this.chain = this.core.createArm({ joints: settings.joints, jointType: settings.jointType, limits: settings.limits });
      this.mesh = new ChainMesh(settings.joints, Math.max(0.03, 0.12 * Math.min(1, 6 / settings.joints)));
      this.scene.add(this.mesh.group);
    }
    const chain = this.chain!;
    chain.setOptions({
      maxIterations: this.core.benchMaxIterations(settings.solver),
      positionTolerance: ARM_TOLERANCE,
      orientationTolerance: ARM_TOLERANCE,
      warmStart: true,
      maxRestarts: settings.restarts,
    });
    const p = this.target.position;
    const q = this.target.quaternion;
    chain.setGoals(settings.orientation
      ? [{ kind: 'position', target: [p.x, p.y, p.z] }, { kind: 'orientation', quaternion: [q.x, q.y, q.z, q.w] }]
      : [{ kind: 'position', target: [p.x, p.y, p.z] }]);
    this.solveTimesUs = [];
  }

  // One frame: goals from the target, one solve (timed in the page), the mesh from the core's FK.
  update(): void {
    const chain = this.chain!;
    const p = this.target.position;
    chain.setGoalPosition(0, [p.x, p.y, p.z]);
    if (this.settings.orientation) {
      const q = this.target.quaternion;
      chain.setGoalOrientation(1, [q.x, q.y, q.z, q.w]);
    }
    const t0 = performance.now();
    chain.solveFast(this.settings.solver);
    const t1 = performance.now();
    this.lastResult = chain.result();
    this.solveTimesUs.push((t1 - t0) * 1000);
    if (this.solveTimesUs.length > 60) this.solveTimesUs.shift();
    this.mesh!.update(chain.frames());
  }

  // Mean of the last 60 frames' solve times, about a second: the browser's timer is coarse (5 µs
  // when cross-origin isolated), so one solve alone reads as 0 or a tick; the mean is what it measures.
  get meanSolveUs(): number {
    const t = this.solveTimesUs;
    return t.length ? t.reduce((a, b) => a + b, 0) / t.length : NaN;
  }

  get chainTolerance(): number { return ARM_TOLERANCE; }
  get maxRestarts(): number { return this.chain!.options.maxRestarts; }
}
