// The 3D/2D view: the scene's objects (from the exploded-view GLB, which carries each object's
// geometry and displacement), each in its own colour of a qualitative palette, and the GVD
// (gvd.glb), coloured here from its exact per-vertex clearance (`_CLEARANCE`) through the one
// ramp of the legend (linear or log, adjustable range). Picking, k-ring highlighting, per-object
// visibility and opacity, a clipping plane, the up axis, an axes inset, paths, measurements,
// marks, and the exploded view.
import * as THREE from 'three';
import {OrbitControls} from 'three/addons/controls/OrbitControls.js';
import {GLTFLoader} from 'three/addons/loaders/GLTFLoader.js';
import {LineMaterial} from 'three/addons/lines/LineMaterial.js';
import {LineSegments2} from 'three/addons/lines/LineSegments2.js';
import {LineSegmentsGeometry} from 'three/addons/lines/LineSegmentsGeometry.js';

const kSelected = new THREE.Color(0xffffff);
const kRingColors = [new THREE.Color(0xff7a00), new THREE.Color(0xffd000), new THREE.Color(0x9bd45a),
                     new THREE.Color(0x5ab4d4)];
const kDimmed = new THREE.Color(0x5a5f66);
const kPathColor = 0xff2bd6;
const kMeasureColor = 0x00e5ff;
const kTightColor = 0xff9f1c;

/**
 * The objects' qualitative palette (Tableau 10 without its red, which the clearance ramp uses
 * for "tight", and grey, which is the dimmed colour), by object index.
 */
export const kObjectPalette = ['#4e79a7', '#f28e2b', '#76b7b2', '#59a14f', '#edc948', '#b07aa1', '#ff9da7',
                               '#9c755f', '#86bcb6', '#d4a6c8', '#8cd17d', '#a0cbe8'];

/** The clearance ramp (sRGB): red = tight at t = 0, through yellow and green, to blue = wide at 1. */
const kRampStops = [[1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1]];

/** The ramp's sRGB colour at t in [0, 1], components in [0, 1]. */
export function ramp(t) {
  const u = Math.min(1, Math.max(0, Number.isFinite(t) ? t : 0)) * (kRampStops.length - 1);
  const i = Math.min(kRampStops.length - 2, Math.floor(u));
  const f = u - i;
  return kRampStops[i].map((a, k) => a + (kRampStops[i + 1][k] - a) * f);
}

/**
 * Where a clearance lies on the ramp for a scale {scale: 'linear'|'log', min, max}: linear
 * (c - min) / (max - min); log (log c - log min) / (log max - log min), clamped to [0, 1]
 * (clearance 0, touching, is at 0 either way).
 */
export function rampPosition(c, {scale, min, max}) {
  let t;
  if (scale === 'log') {
    if (!(c > 0) || !(min > 0)) return 0;
    t = (Math.log(c) - Math.log(min)) / (Math.log(max) - Math.log(min));
  } else {
    t = (c - min) / (max - min);
  }
  return Math.min(1, Math.max(0, Number.isFinite(t) ? t : 0));
}

function parseGlb(bytes) {
  return new Promise((resolve, reject) => {
    new GLTFLoader().parse(bytes, '', resolve, (e) => reject(new Error(`cannot read the GLB: ${e.message ?? e}`)));
  });
}

/**
 * A wide copy of a LINES object (WebGL draws 1-pixel lines only), added as its sibling; the
 * thin original stays for picking. `width` in pixels.
 */
function widen(lines, width, color) {
  const g = lines.geometry;
  const pos = g.attributes.position;
  const index = g.index ? g.index.array : [...Array(pos.count).keys()];
  const p = new Float32Array(index.length * 3);
  index.forEach((v, k) => p.set([pos.getX(v), pos.getY(v), pos.getZ(v)], 3 * k));
  const geometry = new LineSegmentsGeometry().setPositions(p);
  const withColors = color === undefined && g.attributes.color !== undefined;
  const material = new LineMaterial({linewidth: width, vertexColors: withColors, color: color ?? 0xffffff});
  const wide = new LineSegments2(geometry, material);
  wide.raycast = () => {};
  wide.userData.index = index;
  wide.position.copy(lines.position);
  wide.quaternion.copy(lines.quaternion);
  wide.scale.copy(lines.scale);
  lines.parent.add(wide);
  if (withColors) copyColors(lines, wide);
  return wide;
}

/** Copies the vertex colours of a LINES object onto its wide copy. */
function copyColors(lines, wide) {
  const col = lines.geometry.attributes.color;
  const index = wide.userData.index;
  const c = new Float32Array(index.length * 3);
  index.forEach((v, k) => c.set([col.getX(v), col.getY(v), col.getZ(v)], 3 * k));
  wide.geometry.setColors(c);
}

/** A text sprite (for the axes inset). */
function textSprite(text, color) {
  const c = document.createElement('canvas');
  c.width = c.height = 64;
  const g = c.getContext('2d');
  g.fillStyle = color;
  g.font = 'bold 44px system-ui, sans-serif';
  g.textAlign = 'center';
  g.textBaseline = 'middle';
  g.fillText(text, 32, 34);
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({map: new THREE.CanvasTexture(c), depthTest: false}));
  sprite.scale.set(0.5, 0.5, 1);
  return sprite;
}

const kAxes = [['x', [1, 0, 0], '#e5484d'], ['y', [0, 1, 0], '#46c758'], ['z', [0, 0, 1], '#3e8ed0']];
const kGizmoPixels = 96;  // the axes inset's side (CSS pixels), bottom-left of the view
/** Kinds of overlay placed in the assembled scene's coordinates: hidden while exploded. */
const kSceneOverlays = new Set(['marker', 'path', 'measure', 'tight']);

export class GvdView {
  constructor(canvas) {
    this.canvas = canvas;
    this.selected = null;  // label of the highlighted object
    this.selectedCellOnly = false;
    this.soloCell = null;  // label whose cell alone is drawn (the object list's "cell")
    this.renderer = new THREE.WebGLRenderer({canvas, antialias: true, preserveDrawingBuffer: true});
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.setClearColor(0x1d2127);
    this.scene = new THREE.Scene();
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x404048, 1.6));
    this.light = new THREE.DirectionalLight(0xffffff, 1.8);
    this.scene.add(this.light);
    this.objects = new THREE.Group();
    this.gvd = new THREE.Group();
    this.overlay = new THREE.Group();
    this.scene.add(this.objects, this.gvd, this.overlay);
    this.dimension = 3;
    this.up = 'z';
    this.size = 1;
    this.byLabel = new Map();  // label -> {label, object, node, gvdNode, displacement, parts, gvdParts, color}
    this.explodeT = 0;
    this.clipPlane = null;
    this.showAxes = true;
    this.rampScale = {scale: 'linear', min: 0, max: 1};
    this.onChange = () => {};  // called after the camera moved (scale bar)
    this.needsRender = true;
    this.raycaster = new THREE.Raycaster();
    this.makeGizmo();
    this.setCamera(3);
    new ResizeObserver(() => this.resize()).observe(canvas.parentElement);
    this.resize();
    const loop = () => {
      if (this.needsRender) {
        this.needsRender = false;
        this.draw();
        this.frames = (this.frames ?? 0) + 1;
      }
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  render() {
    this.needsRender = true;
  }

  draw() {
    this.light.position.copy(this.camera.position);
    this.renderer.clippingPlanes = this.clipPlane ? [this.clipPlane] : [];
    this.renderer.render(this.scene, this.camera);
    this.renderer.clippingPlanes = [];
    if (this.showAxes && this.byLabel.size > 0) this.drawGizmo();
  }

  // ---- the axes inset --------------------------------------------------------------------

  makeGizmo() {
    this.gizmoScene = new THREE.Scene();
    for (const [name, dir, color] of kAxes) {
      const tip = new THREE.Vector3(...dir);
      const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), tip]),
                                  new THREE.LineBasicMaterial({color, depthTest: false}));
      const cone = new THREE.Mesh(new THREE.ConeGeometry(0.07, 0.22, 12), new THREE.MeshBasicMaterial({color, depthTest: false}));
      cone.position.copy(tip).multiplyScalar(0.9);
      cone.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), tip);
      const text = textSprite(name, color);
      text.position.copy(tip).multiplyScalar(1.3);
      this.gizmoScene.add(line, cone, text);
    }
    this.gizmoCamera = new THREE.OrthographicCamera(-1.7, 1.7, 1.7, -1.7, -10, 10);
  }

  drawGizmo() {
    const r = this.renderer;
    this.gizmoCamera.quaternion.copy(this.camera.quaternion);
    this.gizmoCamera.position.set(0, 0, 0);
    this.gizmoCamera.updateMatrixWorld();
    const size = r.getSize(new THREE.Vector2());
    r.autoClear = false;
    r.setScissorTest(true);
    r.setScissor(0, 0, kGizmoPixels, kGizmoPixels);
    r.setViewport(0, 0, kGizmoPixels, kGizmoPixels);
    r.clearDepth();
    r.render(this.gizmoScene, this.gizmoCamera);
    r.setScissorTest(false);
    r.setViewport(0, 0, size.x, size.y);
    r.autoClear = true;
  }

  /**
   * The axes inset's x, y, z as unit directions on the screen (y down), for the test: they
   * must point where the view's own axes do.
   */
  gizmoDirections() {
    this.gizmoCamera.quaternion.copy(this.camera.quaternion);
    this.gizmoCamera.updateMatrixWorld();
    return Object.fromEntries(kAxes.map(([name, dir]) => {
      const v = new THREE.Vector3(...dir).project(this.gizmoCamera);
      const len = Math.hypot(v.x, v.y);
      return [name, len < 1e-6 ? null : {x: v.x / len, y: -v.y / len}];
    }));
  }

  // ---- camera ---------------------------------------------------------------------------

  setCamera(dimension) {
    this.controls?.dispose();
    const aspect = this.aspect ?? 1;
    if (dimension === 2) {
      this.camera = new THREE.OrthographicCamera(-aspect, aspect, 1, -1, -1000, 1000);
    } else {
      this.camera = new THREE.PerspectiveCamera(40, aspect, 0.001, 1000);
      // CAD scenes and the bundled examples are z-up; many meshes (the Stanford models) y-up.
      this.camera.up.set(0, this.up === 'y' ? 1 : 0, this.up === 'y' ? 0 : 1);
    }
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.enableRotate = dimension !== 2;
    this.controls.screenSpacePanning = true;
    if (dimension === 2) this.controls.mouseButtons.LEFT = THREE.MOUSE.PAN;
    this.controls.addEventListener('change', () => {
      this.render();
      this.onChange();
    });
  }

  /** The up axis of a 3D view: 'z' (CAD, the default) or 'y' (most mesh files); frames the scene again. */
  setUp(axis) {
    this.up = axis === 'y' ? 'y' : 'z';
    if (this.dimension === 2) return;
    this.setCamera(3);
    if (this.domainBox) this.frame();
  }

  resize() {
    const box = this.canvas.parentElement.getBoundingClientRect();
    const w = Math.max(1, Math.floor(box.width));
    const h = Math.max(1, Math.floor(box.height));
    this.renderer.setSize(w, h, false);
    this.canvas.style.width = `${w}px`;
    this.canvas.style.height = `${h}px`;
    this.aspect = w / h;
    this.updateProjection();
    this.render();
    this.onChange();
  }

  updateProjection() {
    if (this.camera.isOrthographicCamera) {
      const half = (this.viewHalf ?? 1);
      this.camera.left = -half * this.aspect;
      this.camera.right = half * this.aspect;
      this.camera.top = half;
      this.camera.bottom = -half;
    } else {
      this.camera.aspect = this.aspect;
    }
    this.camera.updateProjectionMatrix();
  }

  /** Scene units per CSS pixel at the centre of rotation (the orbit target). */
  unitsPerPixel() {
    const h = this.canvas.clientHeight || 1;
    if (this.camera.isOrthographicCamera) return (this.camera.top - this.camera.bottom) / this.camera.zoom / h;
    const depth = this.camera.position.distanceTo(this.controls.target);
    return (2 * depth * Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2))) / this.camera.zoom / h;
  }

  clear() {
    for (const group of [this.objects, this.gvd, this.overlay]) {
      for (const child of [...group.children]) {
        group.remove(child);
        child.traverse((o) => {
          o.geometry?.dispose();
          if (o.material) for (const m of [o.material].flat()) m.dispose();
        });
      }
    }
    this.byLabel.clear();
    this.selected = null;
    this.soloCell = null;
    this.domainBox = null;
    this.render();
  }

  /**
   * Shows a finished job: `objectsGlb` (the exploded-view GLB: one node per object with its
   * displacement in extras) and `gvdGlb` (the GVD, one node per cell). `domain` = {origin, side}.
   */
  async show({dimension, objectCount, domain, objectsGlb, gvdGlb}) {
    this.clear();
    this.explodeT = 0;
    this.dimension = dimension;
    this.objectCount = objectCount;
    this.setCamera(dimension);
    const generation = (this.generation = (this.generation ?? 0) + 1);
    const [objects, gvd] = await Promise.all([parseGlb(objectsGlb), parseGlb(gvdGlb)]);
    if (generation !== this.generation) return;  // a later show() won

    for (const node of [...objects.scene.children]) {
      const extras = node.userData ?? {};
      if (extras.label === undefined) continue;
      const entry = this.entry(extras.label, extras.object);
      entry.node = node;
      entry.displacement = new THREE.Vector3(...(extras.displacement ?? [0, 0, 0]));
      entry.baseColor = new THREE.Color(kObjectPalette[(extras.object ?? 0) % kObjectPalette.length]);
      node.position.set(0, 0, 0);  // the GLB's rest pose; explode() moves it
      node.traverse((o) => {
        if (!o.material) return;
        o.userData.label = extras.label;
        o.material = o.isMesh
          ? new THREE.MeshStandardMaterial({color: entry.baseColor, roughness: 0.6, metalness: 0.05,
                                            side: THREE.DoubleSide, flatShading: !o.geometry.attributes.normal})
          : new THREE.LineBasicMaterial({color: entry.baseColor});
        entry.parts.push(o);
      });
      if (dimension === 2) entry.wide = entry.parts.filter((o) => o.isLineSegments).map((o) => widen(o, 2.5, entry.baseColor));
      this.objects.add(node);
    }

    let clearanceMax = 0;
    let clearanceMinPositive = Infinity;
    for (const node of [...gvd.scene.children]) {
      const extras = node.userData ?? {};
      if (extras.label === undefined) continue;
      const entry = this.entry(extras.label, extras.object);
      entry.gvdNode = node;
      node.traverse((o) => {
        if (!o.geometry) return;
        const g = o.geometry;
        this.dropBoxFaces(g, objectCount);
        const c = g.attributes._clearance;
        if (c && g.index) {
          for (const i of g.index.array) {
            const x = c.getX(i);
            clearanceMax = Math.max(clearanceMax, x);
            if (x > 0) clearanceMinPositive = Math.min(clearanceMinPositive, x);
          }
        }
        if (!g.attributes.color) g.setAttribute('color', new THREE.BufferAttribute(new Float32Array(g.attributes.position.count * 3), 3));
        o.userData.label = extras.label;
        o.userData.gvd = true;
        o.material = o.isMesh
          ? new THREE.MeshStandardMaterial({vertexColors: true, side: THREE.DoubleSide, transparent: true,
                                            opacity: 0.55, depthWrite: false, roughness: 0.9,
                                            flatShading: !g.attributes.normal})
          : new THREE.LineBasicMaterial({vertexColors: true});
        entry.gvdParts.push(o);
      });
      if (dimension === 2) entry.gvdWide = entry.gvdParts.filter((o) => o.isLineSegments).map((o) => widen(o, 1.5));
      this.gvd.add(node);
    }
    this.clearanceMax = clearanceMax;
    this.clearanceMinPositive = Number.isFinite(clearanceMinPositive) ? clearanceMinPositive : 0;
    this.rampScale = {scale: 'linear', min: 0, max: clearanceMax > 0 ? clearanceMax : 1};
    this.recolor();

    // The domain box, for orientation.
    // `axes` (3D, when the octree turned to the scene's faces): the cube's edge directions.
    const o = domain?.origin ?? [0, 0, 0];
    const side = domain?.side ?? 1;
    const origin = new THREE.Vector3(o[0], o[1], dimension === 2 ? 0 : o[2]);
    const axes = (domain?.axes ?? [[1, 0, 0], [0, 1, 0], [0, 0, 1]]).map((a) => new THREE.Vector3(...a));
    const cube = new THREE.Box3(new THREE.Vector3(0, 0, 0),
                                new THREE.Vector3(side, side, dimension === 2 ? 0 : side));
    const helper = new THREE.Group();
    helper.add(new THREE.Box3Helper(cube, 0x6b7480));
    helper.matrixAutoUpdate = false;
    helper.matrix.makeBasis(axes[0], axes[1], axes[2]).setPosition(origin);
    helper.userData.domain = true;
    this.overlay.add(helper);
    helper.updateMatrixWorld(true);
    this.domainBox = new THREE.Box3().setFromObject(helper);
    this.size = side;
    this.frame();
    this.setExplode(this.explodeT);
  }

  entry(label, object) {
    if (!this.byLabel.has(label)) {
      this.byLabel.set(label, {label, object, parts: [], gvdParts: [], displacement: new THREE.Vector3(),
                               visible: true, opacity: 1});
    }
    return this.byLabel.get(label);
  }

  /** Removes the domain box's pieces (feature id >= the object count: EXT_mesh_features null id). */
  dropBoxFaces(geometry, objectCount) {
    const fid = geometry.attributes._feature_id_0;
    if (!fid || !geometry.index) return;
    const per = this.dimension === 2 ? 2 : 3;
    const src = geometry.index.array;
    const kept = [];
    for (let i = 0; i + per <= src.length; i += per) {
      if (fid.getX(src[i]) < objectCount - 0.5) for (let k = 0; k < per; k++) kept.push(src[i + k]);
    }
    geometry.setIndex(kept);
  }

  // ---- the clearance ramp ------------------------------------------------------------------

  /** Sets the GVD's colour scale {scale: 'linear'|'log', min, max} (clearances, scene units) and recolours. */
  setRamp(rampScale) {
    this.rampScale = {...this.rampScale, ...rampScale};
    this.recolor();
  }

  /** GVD vertex colours from the exact clearance at each vertex through the legend's ramp. */
  recolor() {
    const color = new THREE.Color();
    for (const e of this.byLabel.values()) {
      for (const part of e.gvdParts) {
        const g = part.geometry;
        const c = g.attributes._clearance;
        const col = g.attributes.color;
        if (!c || !col) continue;
        for (let i = 0; i < c.count; i++) {
          const [r, gg, b] = ramp(rampPosition(c.getX(i), this.rampScale));
          color.setRGB(r, gg, b, THREE.SRGBColorSpace);  // stored linear, drawn as the sRGB ramp
          col.setXYZ(i, color.r, color.g, color.b);
        }
        col.needsUpdate = true;
      }
      e.gvdWide?.forEach((wide, k) => copyColors(e.gvdParts.filter((o) => o.isLineSegments)[k], wide));
    }
    this.render();
  }

  /** A GVD vertex's clearance and drawn colour (sRGB, 0..255), for the test. */
  gvdVertexSample(label, n = 8) {
    const e = this.byLabel.get(label);
    const out = [];
    const color = new THREE.Color();
    for (const part of e?.gvdParts ?? []) {
      const g = part.geometry;
      const ids = [...new Set(g.index?.array ?? [])];
      const step = Math.max(1, Math.floor(ids.length / n));
      for (let k = 0; k < ids.length && out.length < n; k += step) {
        const i = ids[k];
        const col = g.attributes.color;
        color.setRGB(col.getX(i), col.getY(i), col.getZ(i)).convertLinearToSRGB();
        out.push({clearance: g.attributes._clearance.getX(i),
                  position: [g.attributes.position.getX(i), g.attributes.position.getY(i), g.attributes.position.getZ(i)],
                  rgb: [color.r * 255, color.g * 255, color.b * 255]});
      }
    }
    return out;
  }

  frame() {
    const center = this.domainBox.getCenter(new THREE.Vector3());
    const side = this.size;
    if (this.dimension === 2) {
      this.viewHalf = side * 0.55;
      this.camera.position.set(center.x, center.y, 10 * side);
      this.camera.near = -100 * side;
      this.camera.far = 100 * side;
    } else {
      const dir = (this.up === 'y' ? new THREE.Vector3(1.1, 1.0, 1.6) : new THREE.Vector3(1.1, -1.6, 1.0)).normalize();
      this.camera.position.copy(center).addScaledVector(dir, side * 2.0);
      this.camera.near = side * 0.01;
      this.camera.far = side * 20;
    }
    this.camera.zoom = 1;
    this.raycaster.params.Line.threshold = side * 0.01;
    this.updateProjection();
    this.controls.target.copy(center);
    this.controls.update();
    this.render();
    this.onChange();
  }

  /** Back to the first view of the scene (after orbiting, panning, zooming). */
  resetView() {
    if (this.domainBox) this.frame();
  }

  // ---- per object ------------------------------------------------------------------------

  setObjectVisible(label, on) {
    const e = this.byLabel.get(label);
    if (!e?.node) return;
    e.visible = on;
    e.node.visible = on;
    this.render();
  }

  /** An object's opacity in [0, 1] (its parts and, in 2D, their wide copies). */
  setObjectOpacity(label, opacity) {
    const e = this.byLabel.get(label);
    if (!e) return;
    e.opacity = opacity;
    for (const p of [...e.parts, ...(e.wide ?? [])]) {
      p.material.opacity = opacity;
      p.material.transparent = opacity < 1;
      p.material.depthWrite = opacity >= 1;
    }
    this.render();
  }

  /** Draws only `label`'s GVD cell (null: every cell again). */
  setSoloCell(label) {
    this.soloCell = label;
    this.updateCells();
  }

  // ---- clipping ----------------------------------------------------------------------------

  /**
   * A clipping plane square to world axis 'x' | 'y' | 'z' (null: none) at `fraction` of the
   * domain's extent along it; what lies beyond it (greater coordinates, or smaller with `flip`)
   * is cut away, and is not picked either.
   */
  setClip(axis, fraction, flip) {
    if (!axis || !this.domainBox) {
      this.clipPlane = null;
    } else {
      const k = {x: 0, y: 1, z: 2}[axis];
      const lo = this.domainBox.min.getComponent(k);
      const hi = this.domainBox.max.getComponent(k);
      const at = lo + (hi - lo) * fraction;
      const normal = new THREE.Vector3().setComponent(k, flip ? 1 : -1);
      this.clipPlane = new THREE.Plane(normal, flip ? -at : at);
    }
    this.render();
  }

  // ---- visibility --------------------------------------------------------------------------

  setVisible({objects, gvd, opacity, axes}) {
    if (objects !== undefined) this.objects.visible = objects;
    if (gvd !== undefined) this.gvd.visible = gvd;
    if (axes !== undefined) this.showAxes = axes;
    if (opacity !== undefined) {
      for (const e of this.byLabel.values()) for (const p of e.gvdParts) if (p.isMesh) p.material.opacity = opacity;
    }
    this.render();
  }

  /** With `on`, only the selected object's GVD cell is drawn (all cells when none is selected). */
  setSelectedCellOnly(on) {
    this.selectedCellOnly = on;
    this.updateCells();
  }

  updateCells() {
    for (const e of this.byLabel.values()) {
      if (!e.gvdNode) continue;
      if (this.soloCell !== null) e.gvdNode.visible = e.label === this.soloCell;
      else e.gvdNode.visible = !this.selectedCellOnly || this.selected === null || e.label === this.selected;
    }
    this.render();
  }

  /** Colours: the selected object white, its k-ring neighbours by ring, the rest dimmed. */
  highlight(selectedLabel, ringOf) {
    this.selected = selectedLabel;
    this.updateCells();
    for (const e of this.byLabel.values()) {
      let color = e.baseColor;
      if (selectedLabel !== null) {
        if (e.label === selectedLabel) color = kSelected;
        else if (ringOf.has(e.label)) color = kRingColors[Math.min(ringOf.get(e.label), kRingColors.length) - 1];
        else color = kDimmed;
      }
      for (const p of [...e.parts, ...(e.wide ?? [])]) p.material.color.copy(color ?? kDimmed);
    }
    this.render();
  }

  // ---- picking -----------------------------------------------------------------------------

  ndc(clientX, clientY) {
    const r = this.canvas.getBoundingClientRect();
    return new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
  }

  isShown(o) {
    for (let p = o; p; p = p.parent) if (!p.visible) return false;
    return !(o.material && o.material.opacity === 0);
  }

  /** What a ray through a screen point meets, nearest first: only what is drawn (shown, not clipped). */
  hits(clientX, clientY, groups) {
    this.camera.updateMatrixWorld();  // the camera may have moved since the last frame
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    return this.raycaster.intersectObjects(groups.filter((g) => g.visible), true)
      .filter((h) => this.isShown(h.object) && (!this.clipPlane || this.clipPlane.distanceToPoint(h.point) >= 0));
  }

  /** The object under a screen point: its label, or null. */
  objectAt(clientX, clientY) {
    const hit = this.hits(clientX, clientY, [this.objects])[0];
    return hit ? hit.object.userData.label : null;
  }

  /**
   * What lies under a screen point, in the assembled scene's coordinates: 2D: the point on the
   * plane z = 0, with the object or GVD line under it if any; 3D: the nearest surface hit (an
   * object or the GVD), or null. {point, label, onGvd, other (the other object of a GVD
   * interface), exact (the point is the hit itself)}.
   */
  surfaceAt(clientX, clientY) {
    // 2D: lines are picked within a tolerance, so the point may lie near both an object and
    // the GVD; the GVD line wins there.
    const all = this.hits(clientX, clientY, [this.objects, this.gvd]);
    const hit = (this.dimension === 2 ? all.find((h) => h.object.userData.gvd) : undefined) ?? all[0];
    const hitLabel = hit?.object.userData.label ?? null;
    const onGvd = hit ? hit.object.userData.gvd === true : false;
    let other = null;
    if (onGvd) {
      const fid = hit.object.geometry.attributes._feature_id_0;
      const index = hit.object.geometry.index;  // lines: hit.index is the segment's place in the index
      const vertex = hit.face ? hit.face.a : index ? index.getX(hit.index) : hit.index;
      const id = fid && vertex !== undefined ? Math.round(fid.getX(vertex)) : -1;
      other = [...this.byLabel.values()].find((e) => e.object === id)?.label ?? null;
    }
    if (this.dimension === 2) {
      this.camera.updateMatrixWorld();
      this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
      const p = new THREE.Vector3();
      if (!this.raycaster.ray.intersectPlane(new THREE.Plane(new THREE.Vector3(0, 0, 1), 0), p)) return null;
      if (hitLabel !== null) p.sub(this.offsetOf(hitLabel));
      return {point: [p.x, p.y], label: hitLabel, onGvd, other};
    }
    if (!hit) return null;
    const p = hit.point.clone().sub(this.offsetOf(hitLabel));  // back to the assembled scene
    return {point: [p.x, p.y, p.z], label: hitLabel, onGvd, other};
  }

  /**
   * A point to measure from: 3D: on the first object the ray meets, even behind the (see-through)
   * GVD, else on the GVD; 2D: on the plane. In the assembled scene's coordinates, or null.
   */
  measurePointAt(clientX, clientY) {
    if (this.dimension === 3) {
      const hit = this.hits(clientX, clientY, [this.objects])[0];
      if (hit) return hit.point.clone().sub(this.offsetOf(hit.object.userData.label)).toArray();
    }
    return this.surfaceAt(clientX, clientY)?.point ?? null;
  }

  /**
   * A point in free space under a screen point, for paths: 2D: on the plane z = 0; 3D: on the
   * nearest GVD surface, or just in front of the nearest object surface.
   */
  pointAt(clientX, clientY) {
    if (this.dimension === 2) return this.surfaceAt(clientX, clientY)?.point ?? null;
    const hit = this.hits(clientX, clientY, [this.gvd, this.objects])[0];
    if (!hit) return null;
    const p = hit.point.clone();
    if (!hit.object.userData.gvd) p.addScaledVector(this.raycaster.ray.direction, -this.size * 0.004);
    p.sub(this.offsetOf(hit.object.userData.label));  // back to the un-exploded scene
    return [p.x, p.y, p.z];
  }

  offsetOf(label) {
    const e = this.byLabel.get(label);
    return e ? e.displacement.clone().multiplyScalar(this.explodeT) : new THREE.Vector3();
  }

  // ---- exploded view -------------------------------------------------------------------------

  /**
   * Exploded view: every object (and its GVD cell) moved by t x its displacement. Paths,
   * measurements and marks belong to the assembled scene: hidden while t > 0.
   */
  setExplode(t) {
    this.explodeT = t;
    for (const e of this.byLabel.values()) {
      const offset = e.displacement.clone().multiplyScalar(t);
      e.node?.position.copy(offset);
      e.gvdNode?.position.copy(offset);
    }
    for (const c of this.overlay.children) if (kSceneOverlays.has(c.userData.kind)) c.visible = t === 0;
    this.render();
  }

  setDisplacements(byLabel) {
    for (const [label, d] of byLabel) {
      const e = this.byLabel.get(label);
      if (e) e.displacement.set(d[0], d[1], d[2] ?? 0);
    }
    this.setExplode(this.explodeT);
  }

  // ---- overlays ------------------------------------------------------------------------------

  addOverlay(kind, object) {
    object.userData.kind = kind;
    object.visible = !kSceneOverlays.has(kind) || this.explodeT === 0;
    this.overlay.add(object);
    this.render();
  }

  /** Marks points (user units) with small spheres drawn over everything. */
  showMarkers(points, kind = 'marker', color = kPathColor, radius = 0.012) {
    this.clearOverlay(kind);
    for (const p of points) {
      const m = new THREE.Mesh(new THREE.SphereGeometry(this.size * radius, 16, 12),
                               new THREE.MeshBasicMaterial({color, depthTest: false, transparent: true}));
      m.renderOrder = 11;
      m.position.set(p[0], p[1], p[2] ?? 0);
      this.addOverlay(kind, m);
    }
  }

  /** Draws a path polyline (user units) as a tube, so it is visible at any zoom. */
  showPath(points, kind = 'path', color = kPathColor) {
    this.clearOverlay(kind);
    if (points.length < 2) return;
    const curve = new THREE.CurvePath();
    const v = points.map((p) => new THREE.Vector3(p[0], p[1], p[2] ?? 0));
    for (let i = 1; i < v.length; i++) if (v[i].distanceTo(v[i - 1]) > 0) curve.add(new THREE.LineCurve3(v[i - 1], v[i]));
    if (curve.curves.length === 0) return;
    const tube = new THREE.Mesh(
        new THREE.TubeGeometry(curve, Math.max(8, curve.curves.length * 2), this.size * 0.005, 8, false),
        new THREE.MeshBasicMaterial({color, depthTest: false, transparent: true, opacity: 0.9}));
    tube.renderOrder = 10;  // drawn over everything: a path behind an object stays visible
    this.addOverlay(kind, tube);
  }

  /** A measurement: the two points and the segment between them. */
  showMeasure(points) {
    this.clearOverlay('measure');
    for (const p of points) {
      const m = new THREE.Mesh(new THREE.SphereGeometry(this.size * 0.008, 12, 8),
                               new THREE.MeshBasicMaterial({color: kMeasureColor, depthTest: false, transparent: true}));
      m.renderOrder = 12;
      m.position.set(p[0], p[1], p[2] ?? 0);
      this.addOverlay('measure', m);
    }
    if (points.length === 2) {
      const line = new THREE.Line(new THREE.BufferGeometry().setFromPoints(points.map((p) => new THREE.Vector3(p[0], p[1], p[2] ?? 0))),
                                  new THREE.LineBasicMaterial({color: kMeasureColor, depthTest: false, transparent: true}));
      line.renderOrder = 12;
      line.raycast = () => {};
      this.addOverlay('measure', line);
    }
  }

  /** Marks the tightest points (from `tight`). */
  showTight(points) {
    this.showMarkers(points, 'tight', kTightColor, 0.01);
  }

  /** Overlay objects of a kind (for the test). */
  overlays(kind) {
    return this.overlay.children.filter((c) => c.userData.kind === kind);
  }

  clearOverlay(kind) {
    for (const c of [...this.overlay.children]) {
      if (kind === undefined ? !c.userData.domain : c.userData.kind === kind) {
        this.overlay.remove(c);
        c.geometry?.dispose();
        c.material?.dispose();
      }
    }
    this.render();
  }

  /** Centres the view on a point (user units) without changing the viewing direction. */
  lookAt(p) {
    const target = new THREE.Vector3(p[0], p[1], p[2] ?? 0);
    const shift = target.clone().sub(this.controls.target);
    this.camera.position.add(shift);
    this.controls.target.copy(target);
    this.controls.update();
    this.render();
    this.onChange();
  }

  // ---- for the test --------------------------------------------------------------------------

  /** Fraction of pixels of the last frame that differ from the background. */
  coverage() {
    this.draw();
    const gl = this.renderer.getContext();
    const w = gl.drawingBufferWidth;
    const h = gl.drawingBufferHeight;
    const pixels = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    const bg = new THREE.Color(this.renderer.getClearColor(new THREE.Color())).convertLinearToSRGB();
    const [r, g, b] = [bg.r * 255, bg.g * 255, bg.b * 255];
    let drawn = 0;
    for (let i = 0; i < pixels.length; i += 4) {
      if (Math.abs(pixels[i] - r) + Math.abs(pixels[i + 1] - g) + Math.abs(pixels[i + 2] - b) > 12) drawn++;
    }
    return drawn / (w * h);
  }

  /** Window coordinates of a point (user units, at the current explode offset of `label`). */
  toScreen(p, label) {
    this.camera.updateMatrixWorld();
    const v = new THREE.Vector3(p[0], p[1], p[2] ?? 0).add(this.offsetOf(label)).project(this.camera);
    const r = this.canvas.getBoundingClientRect();
    return {x: r.left + ((v.x + 1) / 2) * r.width, y: r.top + ((1 - v.y) / 2) * r.height};
  }

  /** The camera's right-hand screen direction in world units and the orbit target (for the scale bar test). */
  cameraFrame() {
    this.camera.updateMatrixWorld();
    const right = new THREE.Vector3().setFromMatrixColumn(this.camera.matrixWorld, 0).normalize();
    const t = this.controls.target;
    return {right: [right.x, right.y, right.z], target: [t.x, t.y, t.z],
            position: this.camera.position.toArray(), up: this.camera.up.toArray()};
  }

  /**
   * A screen point where `label`'s object is the first thing hit (for tests and the "find"
   * button): tries the projections of its vertices, nearest the object's centre first.
   */
  screenPointOf(label) {
    const e = this.byLabel.get(label);
    if (!e) return null;
    this.scene.updateMatrixWorld(true);
    const r = this.canvas.getBoundingClientRect();
    const candidates = [];
    for (const part of e.parts) {
      const pos = part.geometry.attributes.position;
      const box = new THREE.Box3().setFromBufferAttribute(pos);
      const c = box.getCenter(new THREE.Vector3());
      const step = Math.max(1, Math.floor(pos.count / 200));
      for (let i = 0; i < pos.count; i += step) {
        const q = new THREE.Vector3().fromBufferAttribute(pos, i);
        // a little inside the surface, so the ray meets this object's face there
        if (part.isMesh) q.lerp(c, 0.15);
        candidates.push(q);
      }
      candidates.sort((a, b) => a.distanceTo(c) - b.distanceTo(c));
    }
    for (const q of candidates) {
      const s = this.toScreen([q.x, q.y, q.z], label);
      if (s.x < r.left + 2 || s.x > r.right - 2 || s.y < r.top + 2 || s.y > r.bottom - 2) continue;
      if (this.objectAt(s.x, s.y) === label) return s;
    }
    return null;
  }

  /**
   * A screen point where the nearest hit is the GVD surface between `label` and `other` (for
   * tests): the visible vertex of that interface nearest its centre.
   */
  screenPointOnGvd(label, other) {
    const e = this.byLabel.get(label);
    const o = this.byLabel.get(other);
    if (!e || !o) return null;
    this.scene.updateMatrixWorld(true);
    const r = this.canvas.getBoundingClientRect();
    for (const part of e.gvdParts) {
      const pos = part.geometry.attributes.position;
      const fid = part.geometry.attributes._feature_id_0;
      const ids = [...new Set(part.geometry.index?.array ?? [])].filter((i) => Math.round(fid.getX(i)) === o.object);
      if (ids.length === 0) continue;
      const c = new THREE.Vector3();
      for (const i of ids) c.add(new THREE.Vector3().fromBufferAttribute(pos, i));
      c.divideScalar(ids.length);
      const dist = (i) => new THREE.Vector3().fromBufferAttribute(pos, i).distanceTo(c);
      ids.sort((a, b) => dist(a) - dist(b));
      const stride = Math.max(1, Math.floor(ids.length / 60));  // at most ~60 rays, all over it
      for (let k = 0; k < ids.length; k += stride) {
        const i = ids[k];
        const s = this.toScreen([pos.getX(i), pos.getY(i), pos.getZ(i)], label);
        if (s.x < r.left + 2 || s.x > r.right - 2 || s.y < r.top + 2 || s.y > r.bottom - 2) continue;
        const hit = this.hits(s.x, s.y, [this.gvd, this.objects])[0];
        if (hit && hit.object.userData.gvd) return s;
      }
    }
    return null;
  }
}
