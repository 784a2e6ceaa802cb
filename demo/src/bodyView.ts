// Full body: the humanoid (humanoid.ts) solved as one tree by the core's DLS with priority levels,
// drawn with capsules and spheres from the core's forward kinematics. The targets move by
// themselves (animatedTargets) or, with "animate" off, the user drags them with the gizmo.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { TransformControls } from 'three/examples/jsm/controls/TransformControls.js';
import { CSS2DObject, CSS2DRenderer } from 'three/examples/jsm/renderers/CSS2DRenderer.js';

import type { IKCore, Quat, TerminationReason, Tree, Vec3 } from './ikchain.js';
import { SolverKind } from './ikchain.js';
import { BODY_GOALS, BODY_OPTIONS, BODY_POSTURE_STIFFNESS, CRATE_SIZE, E, HUMANOID, J, SOLE_BELOW_ANKLE, animatedTargets, bodyGoals, relaxedPose, setBodyGoalValues } from './humanoid.js';

const HISTORY = 300; // frames kept for the live charts

export const LEVEL_COLOR = { 1: 0x6fd38c, 2: 0xf7a24f, 3: 0x8ab4f8 } as const;
const SIDE_COLOR = { center: 0xc9ced6, left: 0x4f8ef7, right: 0xe2725b } as const;

// The draggable targets: what each moves and how it is drawn.
export type TargetId = 'leftHand' | 'rightHand' | 'leftFoot' | 'rightFoot' | 'look' | 'hips';
// The hips' target is two goals: its facing (the arrow, level 1; rotate it) and its position (the
// ring, a level-3 hint; move it).
export const TARGETS: readonly { id: TargetId; label: string; level: 1 | 2 | 3 }[] = [
  { id: 'leftHand', label: 'left hand', level: 2 },
  { id: 'rightHand', label: 'right hand', level: 2 },
  { id: 'look', label: 'head looks at', level: 2 },
  { id: 'leftFoot', label: 'left foot', level: 1 },
  { id: 'rightFoot', label: 'right foot', level: 1 },
  { id: 'hips', label: 'hips', level: 3 },
];

function sideOf(name: string): keyof typeof SIDE_COLOR {
  return name.startsWith('Left') ? 'left' : name.startsWith('Right') ? 'right' : 'center';
}

function label(text: string, color: number): CSS2DObject {
  const div = document.createElement('div');
  div.className = 'body-label';
  div.textContent = text;
  div.style.color = `#${color.toString(16).padStart(6, '0')}`;
  return new CSS2DObject(div);
}

export class BodyView {
  readonly scene = new THREE.Scene();
  readonly camera = new THREE.PerspectiveCamera(40, 1, 0.05, 100);
  readonly orbit: OrbitControls;
  readonly gizmo: TransformControls;
  readonly labels = new CSS2DRenderer();
  readonly targets = {} as Record<TargetId, THREE.Object3D>;
  readonly body: Tree;
  animate = true;
  time = 0;
  selected: TargetId = 'rightHand';
  lastReason: TerminationReason = 'converged';
  lastIterations = 0;
  lastUs = NaN; // the last solve, timed in the page (performance.now())
  lastCoreUs = NaN; // the same solve, the core's own timer
  readonly goalErrors = new Float64Array(BODY_GOALS.length);
  lastMessage = '';
  // Per frame, for the charts: time (s), µs, iterations, one error per goal.
  readonly history = { t: [] as number[], us: [] as number[], iterations: [] as number[], errors: BODY_GOALS.map(() => [] as number[]) };
  floor = 0;
  lowestHips = Infinity;
  private readonly floorMesh: THREE.Mesh;
  private readonly crate: THREE.Mesh;
  private readonly jointMeshes: THREE.Mesh[] = [];
  private readonly bones: { mesh: THREE.Mesh; from: number; to: number | { effector: number } }[] = [];
  private readonly headMesh: THREE.Mesh;
  private readonly feetMeshes: THREE.Mesh[] = [];
  private readonly lookLine: THREE.Line;
  private readonly up = new THREE.Vector3(0, 1, 0);
  private readonly tmpA = new THREE.Vector3();
  private readonly tmpB = new THREE.Vector3();
  private enabled = false;
  private skipHistory = 0;

  constructor(core: IKCore, dom: HTMLElement, labelParent: HTMLElement) {
    this.scene.background = new THREE.Color(0x181b22);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x30343c, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(3, 6, 5);
    this.scene.add(sun);
    this.scene.add(new THREE.GridHelper(8, 32, 0x3a3f4a, 0x2a2e37));

    // The floor under the feet (its top at this.floor) and the crate on it.
    this.floorMesh = new THREE.Mesh(new THREE.BoxGeometry(1.4, 0.3, 1.3),
                                    new THREE.MeshStandardMaterial({ color: 0x3a4150, roughness: 0.9 }));
    this.scene.add(this.floorMesh);
    this.crate = new THREE.Mesh(new THREE.BoxGeometry(CRATE_SIZE, CRATE_SIZE, CRATE_SIZE),
                                new THREE.MeshStandardMaterial({ color: 0xa7773f, roughness: 0.8 }));
    this.scene.add(this.crate);

    this.camera.position.set(1.6, 1.25, 2.3);
    this.orbit = new OrbitControls(this.camera, dom);
    this.orbit.target.set(0, 0.62, 0.15);
    this.orbit.update();

    // The body: a sphere per joint, a capsule per bone (rigid: each capsule has its bone's length).
    const jointGeo = new THREE.SphereGeometry(0.028, 16, 12);
    const jointMat = new THREE.MeshStandardMaterial({ color: 0xe0e4ea, roughness: 0.5 });
    const boneMat = (color: number) => new THREE.MeshStandardMaterial({ color, roughness: 0.45, metalness: 0.1 });
    const boneMats: Record<keyof typeof SIDE_COLOR, THREE.Material> =
      { center: boneMat(SIDE_COLOR.center), left: boneMat(SIDE_COLOR.left), right: boneMat(SIDE_COLOR.right) };
    const capsule = (length: number, radius: number, mat: THREE.Material) => {
      const geo = new THREE.CapsuleGeometry(radius, Math.max(1e-3, length - 2 * radius), 4, 12);
      geo.translate(0, length / 2, 0); // from its base along +Y
      const m = new THREE.Mesh(geo, mat);
      this.scene.add(m);
      return m;
    };
    HUMANOID.joints.forEach((j, i) => {
      const s = new THREE.Mesh(jointGeo, jointMat);
      this.jointMeshes.push(s);
      this.scene.add(s);
      if (j.parent >= 0) {
        const len = Math.hypot(...j.offset);
        const radius = j.name.includes('Upper') && j.name.includes('Leg') ? 0.05 : j.name.includes('Leg') ? 0.042
          : j.name.includes('Arm') || j.name.includes('Hand') ? 0.032 : 0.045;
        this.bones.push({ mesh: capsule(len, radius, boneMats[sideOf(j.name)]), from: j.parent, to: i });
      }
    });
    // Hands: wrist to palm.
    for (const [joint, effector] of [[J.lHand, E.lHand], [J.rHand, E.rHand]] as const) {
      const side = joint === J.lHand ? 'left' : 'right';
      this.bones.push({ mesh: capsule(0.08, 0.03, boneMats[side]), from: joint, to: { effector } });
    }
    // Feet: a box from the heel to the toes under each ankle, in the foot's frame.
    for (const joint of [J.lFoot, J.rFoot]) {
      const geo = new THREE.BoxGeometry(0.09, 0.05, 0.24);
      geo.translate(0, -SOLE_BELOW_ANKLE + 0.025, 0.06);
      const m = new THREE.Mesh(geo, boneMats[joint === J.lFoot ? 'left' : 'right']);
      m.userData.joint = joint;
      this.feetMeshes.push(m);
      this.scene.add(m);
    }
    // The head: a skull around the head effector, a nose showing where it faces (+Z).
    this.headMesh = new THREE.Mesh(new THREE.SphereGeometry(0.095, 24, 18), boneMats.center);
    const nose = new THREE.Mesh(new THREE.ConeGeometry(0.025, 0.06, 12), new THREE.MeshStandardMaterial({ color: 0xf7d44f }));
    nose.rotation.x = Math.PI / 2;
    nose.position.set(0, 0, 0.11);
    this.headMesh.add(nose);
    this.scene.add(this.headMesh);

    // Targets, coloured by priority level, each labelled.
    const mat = (level: 1 | 2 | 3) => new THREE.MeshStandardMaterial({ color: LEVEL_COLOR[level], emissive: LEVEL_COLOR[level], emissiveIntensity: 0.35, transparent: true, opacity: 0.85 });
    for (const t of TARGETS) {
      const g = new THREE.Group();
      let mesh: THREE.Mesh;
      if (t.id === 'leftFoot' || t.id === 'rightFoot') {
        mesh = new THREE.Mesh(new THREE.CylinderGeometry(0.06, 0.06, 0.012, 24), mat(t.level));
        mesh.position.y = 0.006;
      } else if (t.id === 'hips') {
        mesh = new THREE.Mesh(new THREE.TorusGeometry(0.16, 0.012, 8, 40), mat(t.level));
        mesh.rotation.x = Math.PI / 2;
        const arrow = new THREE.Mesh(new THREE.ConeGeometry(0.03, 0.08, 12), mat(1));
        arrow.rotation.x = Math.PI / 2;
        arrow.position.set(0, 0, 0.2);
        g.add(arrow);
      } else {
        mesh = new THREE.Mesh(new THREE.SphereGeometry(t.id === 'look' ? 0.045 : 0.04, 20, 14), mat(t.level));
      }
      mesh.userData.target = t.id;
      g.add(mesh);
      const l = label(t.id === 'hips' ? 'hips · 1 facing, 3 position' : `${t.label} · ${t.level}`, LEVEL_COLOR[t.level]);
      l.position.set(t.id === 'hips' ? -0.42 : 0, t.id === 'hips' ? -0.06 : 0.1, 0);
      l.center.set(0.5, 1);
      g.add(l);
      this.targets[t.id] = g;
      this.scene.add(g);
    }
    this.lookLine = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]),
                                   new THREE.LineDashedMaterial({ color: LEVEL_COLOR[2], dashSize: 0.05, gapSize: 0.04 }));
    this.scene.add(this.lookLine);

    this.gizmo = new TransformControls(this.camera, dom);
    this.gizmo.setSize(0.7);
    this.gizmo.addEventListener('dragging-changed', (e) => { this.orbit.enabled = !(e as unknown as { value: boolean }).value; });
    this.scene.add(this.gizmo.getHelper());

    this.labels.domElement.className = 'labels';
    labelParent.appendChild(this.labels.domElement);

    // The tree, its goals at their levels, the posture.
    this.body = core.createTree(HUMANOID);
    const pose = relaxedPose();
    this.body.setParams(pose);
    this.body.setPosture(pose, BODY_POSTURE_STIFFNESS);
    this.body.setOptions(BODY_OPTIONS);
    this.placeAnimated();
    const g = this.goalValues();
    const head = this.body.frames().effectors[E.head];
    this.body.setGoals(bodyGoals(g.feet, g.feetRotation, g.hipsRotation, g.hands,
                                 [g.look[0] - head[0], g.look[1] - head[1], g.look[2] - head[2]], g.hips));
    this.setEnabled(false);
  }

  setEnabled(on: boolean): void {
    this.enabled = on;
    this.orbit.enabled = on;
    this.gizmo.enabled = on && !this.animate;
    this.gizmo.getHelper().visible = on && !this.animate;
    this.labels.domElement.hidden = !on;
  }

  setAnimate(on: boolean): void {
    this.animate = on;
    if (on) this.gizmo.detach(); else this.select(this.selected);
    this.setEnabled(this.enabled);
  }

  select(id: TargetId): void {
    this.selected = id;
    if (this.animate) return;
    this.gizmo.attach(this.targets[id]);
  }

  // Clicking a target picks it for the gizmo (when not animating); returns the pick.
  pick(ndcX: number, ndcY: number): TargetId | undefined {
    const ray = new THREE.Raycaster();
    ray.setFromCamera(new THREE.Vector2(ndcX, ndcY), this.camera);
    const hit = ray.intersectObjects(Object.values(this.targets), true).find((h) => h.object.userData.target);
    return hit?.object.userData.target as TargetId | undefined;
  }

  resize(w: number, h: number): void {
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.labels.setSize(w, h);
  }

  // Jumps the animation to t seconds and starts the charts' history afresh.
  jumpTo(t: number): void {
    this.time = t;
    this.lowestHips = Infinity;
    const h = this.history;
    h.t.length = h.us.length = h.iterations.length = 0;
    for (const e of h.errors) e.length = 0;
    this.skipHistory = 1; // the jump's own frame
  }

  private placeAnimated(): void {
    const a = animatedTargets(this.time);
    this.floor = a.floor;
    this.targets.leftFoot.position.fromArray(a.feet[0]);
    this.targets.rightFoot.position.fromArray(a.feet[1]);
    this.targets.leftHand.position.fromArray(a.hands[0]);
    this.targets.rightHand.position.fromArray(a.hands[1]);
    this.targets.look.position.fromArray(a.look);
    this.targets.hips.quaternion.fromArray(a.hipsRotation);
    this.targets.hips.position.fromArray(a.hips);
    this.crate.position.set(a.crate[0], a.crate[1] - CRATE_SIZE / 2, a.crate[2]);
  }

  private goalValues() {
    const v = (o: THREE.Object3D): Vec3 => [o.position.x, o.position.y, o.position.z];
    const q = (o: THREE.Object3D): Quat => [o.quaternion.x, o.quaternion.y, o.quaternion.z, o.quaternion.w];
    const t = this.targets;
    return {
      feet: [v(t.leftFoot), v(t.rightFoot)] as [Vec3, Vec3],
      feetRotation: [0, 0, 0, 1] as Quat,
      hipsRotation: q(t.hips),
      hips: v(t.hips),
      hands: [v(t.leftHand), v(t.rightHand)] as [Vec3, Vec3],
      look: v(t.look),
    };
  }

  // One frame: targets (animated or dragged) into the goals, one solve, the mesh from the core's FK.
  update(dt: number): void {
    if (this.animate) {
      this.time += dt;
      this.placeAnimated();
    } else {
      // Dragged: the floor follows the lower foot.
      this.floor = Math.min(this.targets.leftFoot.position.y, this.targets.rightFoot.position.y);
    }
    const f0 = this.body.framesArray();
    const head = 7 * HUMANOID.joints.length + 3 * E.head;
    const g = this.goalValues();
    const b = this.body;
    setBodyGoalValues(b, g, [g.look[0] - f0[head], g.look[1] - f0[head + 1], g.look[2] - f0[head + 2]]);
    const t0 = performance.now();
    this.lastReason = b.solveFast(SolverKind.DLS);
    const t1 = performance.now();
    this.lastUs = (t1 - t0) * 1000;
    this.lastCoreUs = b.lastElapsedUs;
    this.lastIterations = b.lastIterations;
    this.goalErrors.set(b.goalErrors());
    if (this.lastReason === 'invalid_input') this.lastMessage = b.result().message;

    const h = this.history;
    if (this.skipHistory > 0) {
      this.skipHistory--;
      this.draw(b.framesArray());
      return;
    }
    h.t.push(this.time);
    h.us.push(this.lastCoreUs);
    h.iterations.push(this.lastIterations);
    this.goalErrors.forEach((e, i) => h.errors[i].push(e));
    if (h.t.length > HISTORY) {
      h.t.shift(); h.us.shift(); h.iterations.shift();
      for (const e of h.errors) e.shift();
    }
    this.draw(b.framesArray());
  }

  private draw(f: Float64Array): void {
    const n = HUMANOID.joints.length;
    const at = (i: number, v: THREE.Vector3) => v.set(f[7 * i], f[7 * i + 1], f[7 * i + 2]);
    const eff = (e: number, v: THREE.Vector3) => v.set(f[7 * n + 3 * e], f[7 * n + 3 * e + 1], f[7 * n + 3 * e + 2]);
    for (let i = 0; i < n; ++i) at(i, this.jointMeshes[i].position);
    for (const bone of this.bones) {
      at(bone.from, this.tmpA);
      if (typeof bone.to === 'number') at(bone.to, this.tmpB); else eff(bone.to.effector, this.tmpB);
      bone.mesh.position.copy(this.tmpA);
      const d = this.tmpB.sub(this.tmpA);
      const len = d.length();
      if (len > 1e-9) bone.mesh.quaternion.setFromUnitVectors(this.up, d.divideScalar(len));
    }
    for (const m of this.feetMeshes) {
      const j = m.userData.joint as number;
      at(j, m.position);
      m.quaternion.set(f[7 * j + 3], f[7 * j + 4], f[7 * j + 5], f[7 * j + 6]);
    }
    eff(E.head, this.headMesh.position);
    this.headMesh.quaternion.set(f[7 * J.head + 3], f[7 * J.head + 4], f[7 * J.head + 5], f[7 * J.head + 6]);
    this.lowestHips = Math.min(this.lowestHips, f[7 * J.hips + 1]);
    const line = this.lookLine.geometry.attributes.position as THREE.BufferAttribute;
    line.setXYZ(0, this.headMesh.position.x, this.headMesh.position.y, this.headMesh.position.z);
    line.setXYZ(1, this.targets.look.position.x, this.targets.look.position.y, this.targets.look.position.z);
    line.needsUpdate = true;
    this.lookLine.computeLineDistances();
    this.floorMesh.position.set(0, this.floor - 0.15, 0.1);
  }

  render(renderer: THREE.WebGLRenderer): void {
    renderer.render(this.scene, this.camera);
    this.labels.render(this.scene, this.camera);
  }
}
