// Draws a chain from the core's joint frames: a sphere per joint, a bone to the next joint (or the
// tip), and a small axis triad on the last joint (the hand).
import * as THREE from 'three';
import type { Frames } from './ikchain.js';

export class ChainMesh {
  readonly group = new THREE.Group();
  private readonly joints: THREE.Mesh[] = [];
  private readonly bones: THREE.Mesh[] = [];
  private readonly hand = new THREE.AxesHelper(0.35);
  private readonly up = new THREE.Vector3(0, 1, 0);

  constructor(jointCount: number, radius: number, color = 0x4f8ef7) {
    const jointGeo = new THREE.SphereGeometry(radius * 1.6, 16, 12);
    const boneGeo = new THREE.CylinderGeometry(radius, radius * 0.7, 1, 12);
    boneGeo.translate(0, 0.5, 0); // from its base along +Y
    const jointMat = new THREE.MeshStandardMaterial({ color: 0xe0e4ea, roughness: 0.5 });
    const boneMat = new THREE.MeshStandardMaterial({ color, roughness: 0.4, metalness: 0.2 });
    for (let i = 0; i < jointCount; ++i) {
      const j = new THREE.Mesh(jointGeo, jointMat);
      const b = new THREE.Mesh(boneGeo, boneMat);
      this.joints.push(j);
      this.bones.push(b);
      this.group.add(j, b);
    }
    this.group.add(this.hand);
  }

  update(f: Frames): void {
    const n = f.joints.length;
    const a = new THREE.Vector3();
    const b = new THREE.Vector3();
    for (let i = 0; i < n; ++i) {
      a.fromArray(f.joints[i].position);
      b.fromArray(i + 1 < n ? f.joints[i + 1].position : f.tip);
      this.joints[i].position.copy(a);
      const bone = this.bones[i];
      bone.position.copy(a);
      const d = b.clone().sub(a);
      const len = d.length();
      bone.scale.set(1, Math.max(len, 1e-6), 1);
      if (len > 1e-9) bone.quaternion.setFromUnitVectors(this.up, d.divideScalar(len));
    }
    const last = f.joints[n - 1];
    this.hand.position.fromArray(f.tip);
    this.hand.quaternion.fromArray(last.quaternion);
  }

  dispose(): void {
    this.group.removeFromParent();
    this.joints[0]?.geometry.dispose();
    this.bones[0]?.geometry.dispose();
  }
}

export function basicScene(): { scene: THREE.Scene; grid: THREE.GridHelper } {
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x181b22);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x30343c, 1.6));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.set(5, 10, 7);
  scene.add(sun);
  const grid = new THREE.GridHelper(20, 20, 0x3a3f4a, 0x2a2e37);
  scene.add(grid);
  // The chain's base: its root joint sits at the origin of base space.
  const base = new THREE.Mesh(new THREE.CylinderGeometry(0.45, 0.55, 0.12, 32),
                              new THREE.MeshStandardMaterial({ color: 0x3a3f4a, roughness: 0.8 }));
  base.position.y = -0.06;
  scene.add(base);
  return { scene, grid };
}
