// SPDX-License-Identifier: MIT
// Shows a face exported by `sunprobe export` (glTF 2.0, y up, metres) lit by its own sun: the glTF's
// KHR_lights_punctual directional light (casting shadows), which a slider turns about the +y (up) axis,
// plus image-based light from the environment map OUT.env.hdr when given (PMREM), exposed by the asset's
// lux_per_fit_unit as the project's renderer would show it. URL query:
//   glb=PATH            the .glb (default face.glb)
//   env=PATH            the environment map written beside it (optional)
//   az=DEG              initial sun azimuth offset (default 0 = as fitted)
//   mode=mask           flat unlit white on black, no panel (for silhouette tests)
//   mode=linear         linear tone mapping: the canvas is sRGB(exposure * radiance), clipped at 1
//                       (for luminance tests against the project's renderer)
//   ui=0                hide the panel (sliders)
//   expr=NAME:W,...     initial morph target (expression) weights, 0..1
//   w,h,fx,fy,cx,cy,R,t a fixed pinhole camera: W x H pixels, OpenCV intrinsics (pixel centres at
//                       integers), R (9 numbers, row-major) and t (3) mapping glTF world points to
//                       camera x right, y down, z forward. Without them: an orbit camera.
// window.sunprobeViewer.status becomes 'ready' after the first frame with the model, or 'error'.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const state = { status: 'loading', message: '' };
window.sunprobeViewer = state;
const q = new URLSearchParams(location.search);
const mask = q.get('mode') === 'mask', linear = q.get('mode') === 'linear';
const $ = (id) => document.getElementById(id);

function numbers(name, n) {
  const v = (q.get(name) || '').split(',').map(Number);
  if (v.length !== n || v.some((x) => !Number.isFinite(x))) throw new Error(`bad ${name}: need ${n} numbers`);
  return v;
}

function fail(e) {
  state.status = 'error';
  state.message = String(e && e.message ? e.message : e);
  $('status').textContent = 'error: ' + state.message;
  console.error(e);
}

// Fixed camera from OpenCV intrinsics/extrinsics. The projection matrix is set directly, so an
// off-centre principal point is kept (glTF cameras cannot express it). Pixel i of the renderer has
// its centre at u = i; in WebGL it is at i + 0.5 from the left edge, hence the half pixel.
function fixedCamera() {
  const [w, h] = [Number(q.get('w')), Number(q.get('h'))];
  const [fx, fy, cx, cy] = ['fx', 'fy', 'cx', 'cy'].map((k) => Number(q.get(k)));
  if (!(w >= 1 && h >= 1 && fx > 0 && fy > 0 && Number.isFinite(cx) && Number.isFinite(cy)))
    throw new Error('bad camera: need w, h, fx, fy > 0 and finite cx, cy');
  const R = numbers('R', 9), t = numbers('t', 3);
  const near = 0.01, far = 1000;
  const cam = new THREE.PerspectiveCamera();
  // OpenCV camera -> GL camera flips y and z: view = diag(1, -1, -1) [R | t].
  const view = new THREE.Matrix4().set(
    R[0], R[1], R[2], t[0],
    -R[3], -R[4], -R[5], -t[1],
    -R[6], -R[7], -R[8], -t[2],
    0, 0, 0, 1);
  view.invert().decompose(cam.position, cam.quaternion, cam.scale);
  cam.projectionMatrix.set(
    2 * fx / w, 0, 1 - 2 * (cx + 0.5) / w, 0,
    0, 2 * fy / h, 2 * (cy + 0.5) / h - 1, 0,
    0, 0, -(far + near) / (far - near), -2 * far * near / (far - near),
    0, 0, -1, 0);
  cam.projectionMatrixInverse.copy(cam.projectionMatrix).invert();
  return { cam, w, h };
}

// Image-based light from the equirectangular map (the Blender/three.js layout, luminance in cd/m^2):
// prefiltered (PMREM) for the diffuse and specular terms of the physical material.
async function environmentMap(renderer, url) {
  const tex = await new HDRLoader().setDataType(THREE.FloatType).loadAsync(url);
  tex.mapping = THREE.EquirectangularReflectionMapping;
  const pmrem = new THREE.PMREMGenerator(renderer);
  const env = pmrem.fromEquirectangular(tex).texture;
  tex.dispose();
  pmrem.dispose();
  return env;
}

// The sun's shadow: the light's shadow camera spans the head's bounding box.
function castShadows(root, sun, box) {
  root.traverse((o) => { if (o.isMesh) { o.castShadow = true; o.receiveShadow = true; } });
  const r = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1e-3);
  const c = sun.shadow.camera;
  [c.left, c.right, c.bottom, c.top, c.near, c.far] = [-r, r, -r, r, 0.01, 4 * r + 0.01];
  sun.shadow.mapSize.set(1024, 1024);
  sun.shadow.bias = -0.0005;
  sun.shadow.normalBias = 0.002;
  const centre = box.getCenter(new THREE.Vector3());
  // The light sits 2r from the head towards the sun (its target, a child at local -z, keeps the direction).
  return () => {
    const d = new THREE.Vector3(0, 0, 1).applyQuaternion(sun.getWorldQuaternion(new THREE.Quaternion()));
    sun.position.copy(sun.parent.worldToLocal(centre.clone().addScaledVector(d, 2 * r)));
    sun.updateMatrixWorld(true);
  };
}

function flatWhite(root) {
  root.traverse((o) => {
    if (o.isMesh) o.material = new THREE.MeshBasicMaterial({ color: 0xffffff, side: o.material.side });
    if (o.isLight) o.visible = false;
  });
}

// One slider per morph target (the export's ARKit-named expressions, plain .glb only); weights add to
// the expression the mesh was fitted with. A slider drives its target in every primitive (skin, eyes,
// mouth: three.js makes each a mesh of its own). The URL's expr=NAME:W,... sets initial weights.
function expressionSliders(root, render) {
  const initial = new Map((q.get('expr') || '').split(',').filter(Boolean).map((e) => e.split(':'))
    .map(([n, w]) => [n, Number(w)]));
  const users = new Map(); // target name -> [[mesh, index], ...]
  root.traverse((o) => {
    if (!o.isMesh || !o.morphTargetDictionary) return;
    for (const [name, k] of Object.entries(o.morphTargetDictionary)) {
      if (!users.has(name)) users.set(name, []);
      users.get(name).push([o, k]);
    }
  });
  for (const [name, list] of users) {
    const label = document.createElement('label'), input = document.createElement('input');
    Object.assign(input, { type: 'range', min: 0, max: 1, step: 0.01, value: initial.get(name) || 0 });
    label.append(`${name}: `, input);
    $('expressions').append(label);
    const apply = () => { for (const [o, k] of list) o.morphTargetInfluences[k] = Number(input.value); };
    input.addEventListener('input', () => { apply(); render(); });
    apply();
  }
}

async function main() {
  const fixed = q.has('fx') ? fixedCamera() : null;
  const renderer = new THREE.WebGLRenderer({ antialias: !mask, preserveDrawingBuffer: true });
  renderer.setPixelRatio(fixed ? 1 : window.devicePixelRatio);
  renderer.setSize(fixed ? fixed.w : window.innerWidth, fixed ? fixed.h : window.innerHeight);
  // The project's renderer shows gamma(reinhard(exposure * radiance)); three's Reinhard + sRGB is close.
  renderer.toneMapping = mask ? THREE.NoToneMapping : linear ? THREE.LinearToneMapping : THREE.ReinhardToneMapping;
  renderer.shadowMap.enabled = !mask;
  renderer.shadowMap.type = THREE.PCFSoftShadowMap;
  document.body.appendChild(renderer.domElement);
  if (mask || linear || q.get('ui') === '0') $('panel').style.display = 'none';

  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x000000);
  const draco = new DRACOLoader().setDecoderPath('./node_modules/three/examples/jsm/libs/draco/');
  const loader = new GLTFLoader().setDRACOLoader(draco);
  const gltf = await loader.loadAsync(q.get('glb') || 'face.glb');
  const root = gltf.scene;
  scene.add(root);
  // The sun is in lux and the sky in cd/m^2 (export/EXPORT.md, "Photometry"); this factor brings them back
  // to the project's display scale, where the renderer's exposure 1 applies.
  const extras = ((gltf.parser.json.asset || {}).extras || {}).sunprobe || {};
  const lux = extras.lux_per_fit_unit > 0 ? extras.lux_per_fit_unit : 1;

  let sun = null;
  root.traverse((o) => { if (o.isDirectionalLight && !sun) sun = o; });
  // The light's node (a direct child of the glTF scene) carries the fitted rotation.
  let sunNode = sun;
  while (sunNode && sunNode.parent && sunNode.parent !== root) sunNode = sunNode.parent;
  const sunRest = sunNode ? sunNode.quaternion.clone() : null;
  if (mask) flatWhite(root);
  else if (q.get('env')) {
    try { scene.environment = await environmentMap(renderer, q.get('env')); }
    catch (e) { console.warn('environment map not loaded:', e); }
  }

  const box = new THREE.Box3().setFromObject(root);
  const placeSun = sun && !mask ? castShadows(root, sun, box) : null;
  if (sun && !mask) sun.castShadow = true;
  const centre = box.getCenter(new THREE.Vector3());
  let camera, controls = null;
  if (fixed) camera = fixed.cam;
  else {
    // The export puts the head at the origin facing +z, keyframe 0's camera on that side: look from
    // there, far enough back for the bounding sphere to fit the 30 degree field of view.
    camera = new THREE.PerspectiveCamera(30, window.innerWidth / window.innerHeight, 0.01, 1000);
    const toward = new THREE.Vector3(0, 0, 1);
    const radius = box.isEmpty() ? 0.15 : Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1e-3);
    camera.position.copy(centre).addScaledVector(toward, (1.15 * radius) / Math.sin((15 * Math.PI) / 180));
    camera.lookAt(centre);
    controls = new OrbitControls(camera, renderer.domElement);
    controls.target.copy(centre);
    controls.update();
  }

  const render = () => renderer.render(scene, camera);
  const update = () => {
    const az = Number($('azimuth').value), amb = Number($('ambient').value), ev = Number($('exposure').value);
    $('azimuth-value').textContent = az;
    $('ambient-value').textContent = amb;
    $('exposure-value').textContent = ev;
    if (sunNode) {
      const turn = new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(0, 1, 0), (az * Math.PI) / 180);
      sunNode.quaternion.copy(turn).multiply(sunRest);
      sunNode.updateMatrixWorld(true);
      if (placeSun) placeSun();
    }
    scene.environmentIntensity = amb;
    renderer.toneMappingExposure = Math.pow(2, ev) / lux;
    render();
  };
  for (const id of ['azimuth', 'ambient', 'exposure']) $(id).addEventListener('input', update);
  expressionSliders(root, render);
  if (q.has('az')) $('azimuth').value = q.get('az');
  if (controls) controls.addEventListener('change', render);
  window.addEventListener('resize', () => {
    if (fixed) return;
    camera.aspect = window.innerWidth / window.innerHeight;
    camera.updateProjectionMatrix();
    renderer.setSize(window.innerWidth, window.innerHeight);
    render();
  });

  if (sun) {
    sun.updateMatrixWorld(true);
    const d = new THREE.Vector3().setFromMatrixPosition(sun.matrixWorld)
      .sub(new THREE.Vector3().setFromMatrixPosition(sun.target.matrixWorld));
    const fitted = (Math.atan2(d.x, d.z) * 180) / Math.PI;
    $('info').textContent = `fitted sun: azimuth ${fitted.toFixed(0)}° (from +z towards +x), ` +
      `elevation ${((Math.asin(d.y / (d.length() || 1)) * 180) / Math.PI).toFixed(0)}°, ${sun.intensity.toFixed(0)} lx`;
  } else $('info').textContent = 'this asset has no sun (see asset.extras.sunprobe.left_out)';
  update();
  draco.dispose();
  state.status = 'ready';
  $('status').textContent = '';
}

main().catch(fail);
