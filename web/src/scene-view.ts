/**
 * The picture: scene.glb in three.js, seen from the listener's eyes. A lit bundle (baked light
 * as vertex colours, unlit materials) is shown as it is; an unlit one (the scene's surfaces in
 * their materials' colours) gets soft light from its emitters so that it can be seen. The
 * meshes are also what the listener bumps into: castRay answers collide.ts's rays.
 */
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { RectAreaLightUniformsLib } from 'three/examples/jsm/lights/RectAreaLightUniformsLib.js';
import { BundleError, type BundleIndex } from './bundle';
import { cameraYawRad, radians, sonoluxFromThree, threeFromSonolux, type Vec3 } from './coords';
import type { Listener } from './walker';

export class SceneView {
  readonly renderer: THREE.WebGLRenderer;
  readonly scene = new THREE.Scene();
  readonly camera = new THREE.PerspectiveCamera(70, 1, 0.05, 500);
  private readonly solids: THREE.Object3D[] = [];

  constructor(readonly container: HTMLElement) {
    try {
      this.renderer = new THREE.WebGLRenderer({ antialias: true });
    } catch (e) {
      throw new Error(`WebGL is not available in this browser (${(e as Error).message})`);
    }
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.outputColorSpace = THREE.SRGBColorSpace;
    this.scene.background = new THREE.Color(0x101014);
    this.camera.rotation.order = 'YXZ';
    container.appendChild(this.renderer.domElement);
    this.resize();
    window.addEventListener('resize', () => this.resize());
  }

  get canvas(): HTMLCanvasElement {
    return this.renderer.domElement;
  }

  resize(): void {
    const w = this.container.clientWidth || window.innerWidth;
    const h = this.container.clientHeight || window.innerHeight;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
  }

  /** Loads scene.glb; a missing or broken file is a BundleError. */
  async load(url: string, index: BundleIndex): Promise<void> {
    const file = index.sceneFile;
    let res: Response;
    try {
      res = await fetch(url);
    } catch (e) {
      throw new BundleError(file, `could not be fetched (${(e as Error).message})`);
    }
    if (!res.ok) throw new BundleError(file, `could not be fetched (HTTP ${res.status})`);
    const data = await res.arrayBuffer();
    let gltf;
    try {
      gltf = await new GLTFLoader().parseAsync(data, url.replace(/[^/]*$/, ''));
    } catch (e) {
      throw new BundleError(file, `is not a glTF file the viewer can read (${(e as Error).message ?? e})`);
    }
    const root = gltf.scene;
    const emitters: THREE.Mesh[] = [];
    root.traverse((o) => {
      const mesh = o as THREE.Mesh;
      if (!mesh.isMesh) return;
      const mat = mesh.material as THREE.MeshStandardMaterial;
      const emissive = mat.emissive && mat.emissive.getHex() !== 0;
      const isLight = emissive || /^light/.test(mesh.name) || /^light/.test(o.parent?.name ?? '');
      if (isLight) {
        emitters.push(mesh);
        if (emissive) mat.toneMapped = false;
        mat.side = THREE.DoubleSide;
      } else {
        this.solids.push(mesh);
      }
    });
    if (this.solids.length + emitters.length === 0) throw new BundleError(file, 'holds no triangles');
    this.scene.add(root);
    root.updateMatrixWorld(true);
    if (index.sceneLit) {
      this.renderer.toneMapping = THREE.NoToneMapping; // the colours are tone-mapped already
      // Hairline cracks where patches of two surfaces meet would show the background: make it
      // the room's own mean colour rather than black. (Inside a closed room nothing else
      // shows it.)
      const mean = meanVertexColour(this.solids);
      if (mean) this.scene.background = mean;
    } else {
      this.renderer.toneMapping = THREE.ACESFilmicToneMapping;
      this.addLights(emitters, index);
    }
  }

  /** Light for an unlit bundle: an area light under each emitter, and a soft fill standing in
   * for the light the walls pass around. */
  private addLights(emitters: THREE.Mesh[], index: BundleIndex): void {
    RectAreaLightUniformsLib.init();
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0xb0b0b0, 1.5));
    for (const m of emitters) {
      const box = new THREE.Box3().setFromObject(m);
      const size = box.getSize(new THREE.Vector3());
      const centre = box.getCenter(new THREE.Vector3());
      const light = new THREE.RectAreaLight(0xffffff, 8, Math.max(size.x, 0.05), Math.max(size.z, 0.05));
      light.position.copy(centre).add(new THREE.Vector3(0, -0.01, 0));
      light.lookAt(centre.x, centre.y - 1, centre.z);
      this.scene.add(light);
    }
    if (emitters.length === 0) {
      const [x, y, z] = threeFromSonolux([
        (index.boundsMin[0] + index.boundsMax[0]) / 2,
        (index.boundsMin[1] + index.boundsMax[1]) / 2,
        index.boundsMax[2] - 0.1,
      ]);
      const p = new THREE.PointLight(0xffffff, 20, 0, 2);
      p.position.set(x, y, z);
      this.scene.add(p);
    }
  }

  /** Puts the camera at the listener's eyes. */
  setListener(l: Listener, headHeightM: number): void {
    const [x, y, z] = threeFromSonolux([l.x, l.y, headHeightM]);
    this.camera.position.set(x, y, z);
    this.camera.rotation.set(radians(l.pitchDeg), cameraYawRad(l.headingDeg), 0);
  }

  render(): void {
    this.renderer.render(this.scene, this.camera);
  }

  /** Every solid triangle (not the lights), 9 numbers each, in sonolux axes. */
  solidTriangles(): Float32Array {
    const out: number[] = [];
    const v = new THREE.Vector3();
    for (const o of this.solids) {
      const mesh = o as THREE.Mesh;
      const pos = mesh.geometry.getAttribute('position');
      const index = mesh.geometry.getIndex();
      const n = index ? index.count : pos.count;
      for (let k = 0; k < n; k++) {
        v.fromBufferAttribute(pos, index ? index.getX(k) : k).applyMatrix4(mesh.matrixWorld);
        out.push(...sonoluxFromThree([v.x, v.y, v.z]));
      }
    }
    return Float32Array.from(out);
  }

  /** Where a sonolux point appears in the canvas (CSS pixels), or null behind the camera. */
  project(p: Vec3): [number, number] | null {
    const v = new THREE.Vector3(...threeFromSonolux(p)).project(this.camera);
    if (v.z > 1 || v.z < -1) return null;
    const r = this.canvas.getBoundingClientRect();
    return [((v.x + 1) / 2) * r.width + r.left, ((1 - v.y) / 2) * r.height + r.top];
  }
}

/** The mean COLOR_0 of the meshes (linear), or null when they have none. */
function meanVertexColour(objects: THREE.Object3D[]): THREE.Color | null {
  let r = 0;
  let g = 0;
  let b = 0;
  let n = 0;
  for (const o of objects) {
    const c = (o as THREE.Mesh).geometry?.getAttribute('color');
    if (!c) continue;
    for (let i = 0; i < c.count; i++) {
      r += c.getX(i);
      g += c.getY(i);
      b += c.getZ(i);
      n++;
    }
  }
  return n ? new THREE.Color(r / n, g / n, b / n) : null;
}
