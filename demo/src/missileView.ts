// Missile guidance: a launcher built as a chain (base yaw, shoulder, elbow, barrel) aims its barrel
// at the lead intercept point with the core's aim goal (no look-at code here), and fires missiles
// that home with proportional navigation.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';

import { ChainMesh, basicScene } from './chainMesh.js';
import { leadPoint, pnAcceleration } from './guidance.js';
import type { V3 } from './guidance.js';
import type { Chain, IKCore, SolveResult } from './ikchain.js';
import { SolverKind } from './ikchain.js';

const DEG = Math.PI / 180;
const MISSILE_SPEED = 14; // m/s, also the lead computation's projectile speed
const NAVIGATION_CONSTANT = 4;
const MAX_ACCEL = 60; // m/s^2
const HIT_RADIUS = 0.6; // m
const MISSILE_LIFETIME = 6; // s
const FIRE_INTERVAL = 1.5; // s
const FIRE_AIM_ERROR = 2 * DEG;

interface Missile { pos: V3; vel: V3; age: number; mesh: THREE.Mesh; trail: Trail }

const TRAIL_POINTS = 90;

// A fading polyline of an object's last positions.
class Trail {
  readonly line: THREE.Line;
  private readonly positions = new Float32Array(3 * TRAIL_POINTS);
  private count = 0;
  constructor(color: number) {
    const geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.BufferAttribute(this.positions, 3));
    geo.setDrawRange(0, 0);
    this.line = new THREE.Line(geo, new THREE.LineBasicMaterial({ color, transparent: true, opacity: 0.6 }));
    this.line.frustumCulled = false;
  }
  push(p: V3): void {
    if (this.count === TRAIL_POINTS) this.positions.copyWithin(0, 3);
    else this.count++;
    this.positions.set(p, 3 * (this.count - 1));
    const geo = this.line.geometry;
    geo.setDrawRange(0, this.count);
    (geo.getAttribute('position') as THREE.BufferAttribute).needsUpdate = true;
  }
  dispose(): void {
    this.line.removeFromParent();
    this.line.geometry.dispose();
    (this.line.material as THREE.Material).dispose();
  }
}

export class MissileView {
  readonly scene: THREE.Scene;
  readonly camera: THREE.PerspectiveCamera;
  readonly orbit: OrbitControls;
  private readonly chain: Chain;
  private readonly mesh = new ChainMesh(4, 0.14, 0x7bbf5a);
  private readonly targetMesh: THREE.Mesh;
  private readonly leadMarker: THREE.Mesh;
  private readonly missiles: Missile[] = [];
  private readonly targetTrail = new Trail(0xf0d060);
  private readonly missileGeo = new THREE.ConeGeometry(0.22, 1.1, 10);
  private readonly missileMat = new THREE.MeshStandardMaterial({ color: 0xff6a4d, emissive: 0x551100 });
  private time = 0;
  private sinceShot = 0;
  solver: SolverKind = SolverKind.DLS;
  shots = 0;
  hits = 0;
  aimErrorRad = NaN;
  lead = false;
  lastResult?: SolveResult;
  private solveTimesUs: number[] = [];
  private aimErrors: number[] = [];

  constructor(core: IKCore, dom: HTMLElement) {
    this.scene = basicScene().scene;
    this.camera = new THREE.PerspectiveCamera(55, 1, 0.1, 400);
    this.camera.position.set(-17, 13, 22);
    this.orbit = new OrbitControls(this.camera, dom);
    this.orbit.target.set(0, 6, -3);
    this.orbit.update();
    this.chain = core.createChain([
      { type: 'hinge', offset: [0, 0, 0], axis: [0, 1, 0] },                                      // base yaw
      { type: 'hinge', offset: [0, 0.8, 0], axis: [1, 0, 0], limits: { min: -80 * DEG, max: 80 * DEG } },  // shoulder
      { type: 'hinge', offset: [0, 1.4, 0], axis: [1, 0, 0], limits: { min: -100 * DEG, max: 100 * DEG } }, // elbow
      { type: 'hinge', offset: [0, 1.0, 0], axis: [1, 0, 0], limits: { min: -100 * DEG, max: 100 * DEG } }, // barrel
    ], [0, 1.6, 0]);
    // The barrel's own axis (+Y) at the lead point; the pose changes slowly, as a turret's would.
    this.chain.setGoals([{ kind: 'aim', axis: [0, 1, 0], direction: [0, 1, 0] }]);
    this.chain.setOptions({ maxIterations: 30, orientationTolerance: 1e-4, warmStart: true, maxStepAngle: 0.08 });
    this.scene.add(this.mesh.group);
    this.targetMesh = new THREE.Mesh(new THREE.OctahedronGeometry(0.8),
                                     new THREE.MeshStandardMaterial({ color: 0xf0d060, emissive: 0x403000 }));
    this.leadMarker = new THREE.Mesh(new THREE.SphereGeometry(0.35, 10, 8),
                                     new THREE.MeshBasicMaterial({ color: 0x55ddff, wireframe: true }));
    this.scene.add(this.targetMesh, this.leadMarker, this.targetTrail.line);
  }

  setEnabled(on: boolean): void { this.orbit.enabled = on; }

  // The aerial target: a loop around the launcher, rising and falling (about 5 m/s).
  targetState(t: number): { pos: V3; vel: V3 } {
    const w = 0.32;
    const r = 15;
    const pos: V3 = [r * Math.cos(w * t), 8 + 2.5 * Math.sin(2 * w * t), r * Math.sin(w * t) - 3];
    const vel: V3 = [-r * w * Math.sin(w * t), 5 * w * Math.cos(2 * w * t), r * w * Math.cos(w * t)];
    return { pos, vel };
  }

  update(dt: number): void {
    this.time += dt;
    this.sinceShot += dt;
    const { pos: target, vel: targetVel } = this.targetState(this.time);
    this.targetMesh.position.fromArray(target);
    this.targetTrail.push(target);

    // Aim: the barrel pivot (joint 3) toward the lead point; the core's aim goal turns the chain.
    let f = this.chain.frames();
    const pivot = f.joints[3].position as V3;
    const aim = leadPoint(pivot, target, targetVel, MISSILE_SPEED);
    this.lead = aim.lead;
    this.leadMarker.position.fromArray(aim.point);
    const dir: V3 = [aim.point[0] - pivot[0], aim.point[1] - pivot[1], aim.point[2] - pivot[2]];
    this.chain.setAimDirection(0, dir);
    const t0 = performance.now();
    this.chain.solveFast(this.solver);
    this.solveTimesUs.push((performance.now() - t0) * 1000);
    if (this.solveTimesUs.length > 60) this.solveTimesUs.shift();
    this.lastResult = this.chain.result();
    f = this.chain.frames();
    this.mesh.update(f);

    const p3 = f.joints[3].position;
    const barrel = new THREE.Vector3(f.tip[0] - p3[0], f.tip[1] - p3[1], f.tip[2] - p3[2]).normalize();
    const want = new THREE.Vector3(aim.point[0] - p3[0], aim.point[1] - p3[1], aim.point[2] - p3[2]).normalize();
    this.aimErrorRad = barrel.angleTo(want);
    this.aimErrors.push(this.aimErrorRad);
    if (this.aimErrors.length > 60) this.aimErrors.shift();

    if (this.sinceShot >= FIRE_INTERVAL && this.aimErrorRad < FIRE_AIM_ERROR) {
      this.sinceShot = 0;
      this.shots++;
      const m = new THREE.Mesh(this.missileGeo, this.missileMat);
      const trail = new Trail(0xff6a4d);
      this.scene.add(m, trail.line);
      this.missiles.push({ pos: [...f.tip] as V3, vel: [barrel.x * MISSILE_SPEED, barrel.y * MISSILE_SPEED, barrel.z * MISSILE_SPEED], age: 0, mesh: m, trail });
    }

    const up = new THREE.Vector3(0, 1, 0);
    for (let i = this.missiles.length - 1; i >= 0; --i) {
      const m = this.missiles[i];
      const a = pnAcceleration(m.pos, m.vel, target, targetVel, NAVIGATION_CONSTANT, MAX_ACCEL);
      for (let k = 0; k < 3; ++k) m.vel[k] += a[k] * dt;
      const speed = Math.hypot(...m.vel);
      for (let k = 0; k < 3; ++k) {
        m.vel[k] *= MISSILE_SPEED / speed; // constant speed: PN only turns the missile
        m.pos[k] += m.vel[k] * dt;
      }
      m.age += dt;
      m.mesh.position.fromArray(m.pos);
      m.trail.push(m.pos);
      m.mesh.quaternion.setFromUnitVectors(up, new THREE.Vector3(...m.vel).normalize());
      const miss = Math.hypot(target[0] - m.pos[0], target[1] - m.pos[1], target[2] - m.pos[2]);
      if (miss < HIT_RADIUS || m.age > MISSILE_LIFETIME) {
        if (miss < HIT_RADIUS) this.hits++;
        m.mesh.removeFromParent();
        m.trail.dispose();
        this.missiles.splice(i, 1);
      }
    }
  }

  get meanSolveUs(): number {
    const t = this.solveTimesUs;
    return t.length ? t.reduce((a, b) => a + b, 0) / t.length : NaN;
  }

  get meanAimErrorRad(): number {
    const e = this.aimErrors;
    return e.length ? e.reduce((a, b) => a + b, 0) / e.length : NaN;
  }
}
