// The 3D/2D view: the scene's objects (from the exploded-view GLB, which carries each object's
// geometry and displacement) and the GVD (gvd.glb, coloured by clearance through COLOR_0),
// picking, k-ring highlighting, paths and the exploded view.
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
  const col = g.attributes.color;
  const index = g.index ? g.index.array : [...Array(pos.count).keys()];
  const p = new Float32Array(index.length * 3);
  const c = col ? new Float32Array(index.length * 3) : null;
  index.forEach((v, k) => {
    p.set([pos.getX(v), pos.getY(v), pos.getZ(v)], 3 * k);
    if (c) c.set([col.getX(v), col.getY(v), col.getZ(v)], 3 * k);
  });
  const geometry = new LineSegmentsGeometry().setPositions(p);
  if (c) geometry.setColors(c);
  const material = new LineMaterial({linewidth: width, vertexColors: c !== null, color: color ?? 0xffffff});
  const wide = new LineSegments2(geometry, material);
  wide.raycast = () => {};
  wide.position.copy(lines.position);
  wide.quaternion.copy(lines.quaternion);
  wide.scale.copy(lines.scale);
  lines.parent.add(wide);
  return wide;
}

export class GvdView {
  constructor(canvas) {
    this.canvas = canvas;
    this.selected = null;  // label of the highlighted object
    this.selectedCellOnly = false;
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
    this.size = 1;
    this.byLabel = new Map();  // label -> {object, node, gvdNode, displacement, material(s)}
    this.explodeT = 0;
    this.needsRender = true;
    this.raycaster = new THREE.Raycaster();
    this.setCamera(3);
    new ResizeObserver(() => this.resize()).observe(canvas.parentElement);
    this.resize();
    const loop = () => {
      if (this.needsRender) {
        this.needsRender = false;
        this.light.position.copy(this.camera.position);
        this.renderer.render(this.scene, this.camera);
        this.frames = (this.frames ?? 0) + 1;
      }
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  render() {
    this.needsRender = true;
  }

  setCamera(dimension) {
    this.controls?.dispose();
    const aspect = this.aspect ?? 1;
    if (dimension === 2) {
      this.camera = new THREE.OrthographicCamera(-aspect, aspect, 1, -1, -1000, 1000);
    } else {
      this.camera = new THREE.PerspectiveCamera(40, aspect, 0.001, 1000);
      this.camera.up.set(0, 0, 1);  // scenes are usually z-up (CAD, the bundled examples)
    }
    this.controls = new OrbitControls(this.camera, this.canvas);
    this.controls.enableRotate = dimension !== 2;
    this.controls.screenSpacePanning = true;
    if (dimension === 2) this.controls.mouseButtons.LEFT = THREE.MOUSE.PAN;
    this.controls.addEventListener('change', () => this.render());
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
      node.position.set(0, 0, 0);  // the GLB's rest pose; explode() moves it
      node.traverse((o) => {
        if (!o.material) return;
        o.userData.label = extras.label;
        const base = o.material.color.clone();
        o.material = o.isMesh
          ? new THREE.MeshStandardMaterial({color: base, roughness: 0.6, metalness: 0.05, side: THREE.DoubleSide,
                                            flatShading: !o.geometry.attributes.normal})
          : new THREE.LineBasicMaterial({color: base});
        entry.parts.push(o);
        entry.baseColor = base;
      });
      if (dimension === 2) entry.wide = entry.parts.filter((o) => o.isLineSegments).map((o) => widen(o, 2.5, entry.baseColor));
      this.objects.add(node);
    }

    let clearanceMax = 0;
    for (const node of [...gvd.scene.children]) {
      const extras = node.userData ?? {};
      if (extras.label === undefined) continue;
      const entry = this.entry(extras.label, extras.object);
      entry.gvdNode = node;
      node.traverse((o) => {
        if (!o.geometry) return;
        const g = o.geometry;
        const c = g.attributes._clearance;
        if (c) for (let i = 0; i < c.count; i++) clearanceMax = Math.max(clearanceMax, c.getX(i));
        this.dropBoxFaces(g, objectCount);
        o.userData.label = extras.label;
        o.userData.gvd = true;
        o.material = o.isMesh
          ? new THREE.MeshStandardMaterial({vertexColors: true, side: THREE.DoubleSide, transparent: true,
                                            opacity: 0.55, depthWrite: false, roughness: 0.9,
                                            flatShading: !g.attributes.normal})
          : new THREE.LineBasicMaterial({vertexColors: true});
        entry.gvdParts.push(o);
      });
      if (dimension === 2) entry.gvdParts.filter((o) => o.isLineSegments).forEach((o) => widen(o, 1.5));
      this.gvd.add(node);
    }
    this.clearanceMax = clearanceMax;

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
      this.byLabel.set(label, {label, object, parts: [], gvdParts: [], displacement: new THREE.Vector3()});
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

  frame() {
    const center = this.domainBox.getCenter(new THREE.Vector3());
    const side = this.size;
    if (this.dimension === 2) {
      this.viewHalf = side * 0.55;
      this.camera.position.set(center.x, center.y, 10 * side);
      this.camera.near = -100 * side;
      this.camera.far = 100 * side;
      this.camera.zoom = 1;
    } else {
      const dir = new THREE.Vector3(1.1, -1.6, 1.0).normalize();
      this.camera.position.copy(center).addScaledVector(dir, side * 2.0);
      this.camera.near = side * 0.01;
      this.camera.far = side * 20;
    }
    this.raycaster.params.Line.threshold = side * 0.01;
    this.updateProjection();
    this.controls.target.copy(center);
    this.controls.update();
    this.render();
  }

  /** Exploded view: every object (and its GVD cell) moved by t x its displacement. */
  setExplode(t) {
    this.explodeT = t;
    for (const e of this.byLabel.values()) {
      const offset = e.displacement.clone().multiplyScalar(t);
      e.node?.position.copy(offset);
      e.gvdNode?.position.copy(offset);
    }
    this.render();
  }

  setDisplacements(byLabel) {
    for (const [label, d] of byLabel) {
      const e = this.byLabel.get(label);
      if (e) e.displacement.set(d[0], d[1], d[2] ?? 0);
    }
    this.setExplode(this.explodeT);
  }

  setVisible({objects, gvd, opacity}) {
    if (objects !== undefined) this.objects.visible = objects;
    if (gvd !== undefined) this.gvd.visible = gvd;
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
      if (e.gvdNode) e.gvdNode.visible = !this.selectedCellOnly || this.selected === null || e.label === this.selected;
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

  ndc(clientX, clientY) {
    const r = this.canvas.getBoundingClientRect();
    return new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
  }

  hits(clientX, clientY, groups) {
    this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
    return this.raycaster.intersectObjects(groups.filter((g) => g.visible), true);
  }

  /** The object under a screen point: its label, or null. */
  objectAt(clientX, clientY) {
    const hit = this.hits(clientX, clientY, [this.objects])[0];
    return hit ? hit.object.userData.label : null;
  }

  /**
   * A point in free space under a screen point, for paths: 2D: on the plane z = 0; 3D: on the
   * nearest GVD surface, or just in front of the nearest object surface.
   */
  pointAt(clientX, clientY) {
    if (this.dimension === 2) {
      this.raycaster.setFromCamera(this.ndc(clientX, clientY), this.camera);
      const p = new THREE.Vector3();
      return this.raycaster.ray.intersectPlane(new THREE.Plane(new THREE.Vector3(0, 0, 1), 0), p) ? [p.x, p.y] : null;
    }
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

  /** Marks picked path points; `points` in user units. */
  showMarkers(points) {
    this.clearOverlay('marker');
    for (const p of points) {
      const m = new THREE.Mesh(new THREE.SphereGeometry(this.size * 0.012, 16, 12),
                               new THREE.MeshBasicMaterial({color: kPathColor, depthTest: false, transparent: true}));
      m.renderOrder = 11;
      m.position.set(p[0], p[1], p[2] ?? 0);
      m.userData.kind = 'marker';
      this.overlay.add(m);
    }
    this.render();
  }

  /** Draws a path polyline (user units) as a tube, so it is visible at any zoom. */
  showPath(points) {
    this.clearOverlay('path');
    if (points.length < 2) return;
    const curve = new THREE.CurvePath();
    const v = points.map((p) => new THREE.Vector3(p[0], p[1], p[2] ?? 0));
    for (let i = 1; i < v.length; i++) if (v[i].distanceTo(v[i - 1]) > 0) curve.add(new THREE.LineCurve3(v[i - 1], v[i]));
    if (curve.curves.length === 0) return;
    const tube = new THREE.Mesh(
        new THREE.TubeGeometry(curve, Math.max(8, curve.curves.length * 2), this.size * 0.005, 8, false),
        new THREE.MeshBasicMaterial({color: kPathColor, depthTest: false, transparent: true, opacity: 0.9}));
    tube.renderOrder = 10;  // drawn over everything: a path behind an object stays visible
    tube.userData.kind = 'path';
    this.overlay.add(tube);
    this.render();
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

  /** Fraction of pixels of the last frame that differ from the background. */
  coverage() {
    this.renderer.render(this.scene, this.camera);
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
    const v = new THREE.Vector3(p[0], p[1], p[2] ?? 0).add(this.offsetOf(label)).project(this.camera);
    const r = this.canvas.getBoundingClientRect();
    return {x: r.left + ((v.x + 1) / 2) * r.width, y: r.top + ((1 - v.y) / 2) * r.height};
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
