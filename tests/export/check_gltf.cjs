// SPDX-License-Identifier: MIT
// Independent checks of a sunprobe face export: the Khronos glTF validator on
// both .glb files, and the draco3dgltf decoder reading the Draco .glb back and
// matching every decoded vertex and triangle against the uncompressed export.
// usage: node check_gltf.cjs DRACO.glb|- PLAIN.glb POSITION_BITS UV_BITS; exit 0 = pass, 1 = fail.
// With '-' (a build without Draco) only the plain file is validated.
'use strict';
const fs = require('fs');
const validator = require('gltf-validator');
const draco3d = require('draco3dgltf');

function parseGlb(buf) {
  if (buf.readUInt32LE(0) !== 0x46546c67 || buf.readUInt32LE(4) !== 2) throw new Error('not a GLB 2');
  const jsonLen = buf.readUInt32LE(12);
  const json = JSON.parse(buf.subarray(20, 20 + jsonLen).toString('utf8'));
  const binLen = buf.readUInt32LE(20 + jsonLen);
  const bin = buf.subarray(28 + jsonLen, 28 + jsonLen + binLen);
  return { json, bin };
}

function view(g, index) {
  const v = g.json.bufferViews[index];
  return g.bin.subarray(v.byteOffset || 0, (v.byteOffset || 0) + v.byteLength);
}

function accessor(g, index, Type) {
  const a = g.json.accessors[index];
  const b = view(g, a.bufferView);
  const copy = Buffer.from(b); // aligned copy
  return new Type(copy.buffer, copy.byteOffset, copy.byteLength / Type.BYTES_PER_ELEMENT);
}

async function validate(path) {
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(path)), {
    uri: path, maxIssues: 100, externalResourceFunction: () => Promise.reject(new Error('no external resources')),
  });
  const bad = report.issues.messages.filter((m) => m.severity <= 1);
  for (const m of bad) console.error(`${path}: ${m.severity ? 'warning' : 'error'} ${m.code} ${m.pointer || ''}: ${m.message}`);
  console.log(`${path}: validator ${report.issues.numErrors} errors, ${report.issues.numWarnings} warnings, ` +
    `${report.issues.numInfos} infos, ${report.issues.numHints} hints`);
  return report.issues.numErrors === 0 && report.issues.numWarnings === 0;
}

function decodeDraco(dm, g, pi) {
  const prim = g.json.meshes[0].primitives[pi];
  const ext = prim.extensions && prim.extensions.KHR_draco_mesh_compression;
  if (!ext) throw new Error('primitive has no KHR_draco_mesh_compression');
  const data = view(g, ext.bufferView);
  const decoder = new dm.Decoder();
  const buffer = new dm.DecoderBuffer();
  buffer.Init(new Int8Array(data.buffer, data.byteOffset, data.byteLength), data.byteLength);
  const mesh = new dm.Mesh();
  const status = decoder.DecodeBufferToMesh(buffer, mesh);
  if (!status.ok()) throw new Error('Draco decode failed: ' + status.error_msg());
  const get = (id, n) => {
    const att = decoder.GetAttributeByUniqueId(mesh, id);
    const arr = new dm.DracoFloat32Array();
    decoder.GetAttributeFloatForAllPoints(mesh, att, arr);
    const out = new Float32Array(mesh.num_points() * n);
    for (let i = 0; i < out.length; i++) out[i] = arr.GetValue(i);
    dm.destroy(arr);
    return out;
  };
  const pos = get(ext.attributes.POSITION, 3), uv = get(ext.attributes.TEXCOORD_0, 2);
  const faces = new Uint32Array(mesh.num_faces() * 3), ia = new dm.DracoInt32Array();
  for (let f = 0; f < mesh.num_faces(); f++) {
    decoder.GetFaceFromMesh(mesh, f, ia);
    for (let k = 0; k < 3; k++) faces[f * 3 + k] = ia.GetValue(k);
  }
  const counts = { points: mesh.num_points(), accessorCount: g.json.accessors[prim.attributes.POSITION].count,
    indexCount: g.json.accessors[prim.indices].count };
  dm.destroy(ia); dm.destroy(mesh); dm.destroy(buffer); dm.destroy(decoder);
  return { pos, uv, faces, counts };
}

// For each decoded vertex, the original vertex within half a step per axis (position and UV), by a grid search.
function matchVertices(orig, dec, pstep, ustep) {
  const cell = 4 * pstep, key = (x, y, z) => `${x},${y},${z}`, grid = new Map();
  const cellOf = (p, i) => [0, 1, 2].map((d) => Math.floor(p[i * 3 + d] / cell));
  for (let i = 0; i < orig.pos.length / 3; i++) {
    const k = key(...cellOf(orig.pos, i));
    if (!grid.has(k)) grid.set(k, []);
    grid.get(k).push(i);
  }
  let maxP = 0, maxU = 0, unmatched = 0;
  const map = new Int32Array(dec.pos.length / 3);
  for (let i = 0; i < map.length; i++) {
    const c = cellOf(dec.pos, i);
    let best = -1, bestErr = Infinity;
    for (let dx = -1; dx <= 1; dx++) for (let dy = -1; dy <= 1; dy++) for (let dz = -1; dz <= 1; dz++) {
      for (const j of grid.get(key(c[0] + dx, c[1] + dy, c[2] + dz)) || []) {
        let ep = 0, eu = 0;
        for (let d = 0; d < 3; d++) ep = Math.max(ep, Math.abs(dec.pos[i * 3 + d] - orig.pos[j * 3 + d]));
        for (let d = 0; d < 2; d++) eu = Math.max(eu, Math.abs(dec.uv[i * 2 + d] - orig.uv[j * 2 + d]));
        if (eu <= ustep * 0.5 + 2 ** -22 && ep < bestErr) { best = j; bestErr = ep; }
      }
    }
    map[i] = best;
    if (best < 0) { unmatched++; continue; }
    maxP = Math.max(maxP, bestErr);
    for (let d = 0; d < 2; d++) maxU = Math.max(maxU, Math.abs(dec.uv[i * 2 + d] - orig.uv[best * 2 + d]));
  }
  return { map, maxP, maxU, unmatched };
}

function triangleSet(faces, map) {
  const s = new Map();
  for (let f = 0; f < faces.length / 3; f++) {
    const t = [0, 1, 2].map((k) => (map ? map[faces[f * 3 + k]] : faces[f * 3 + k]));
    // rotation-invariant, orientation-preserving key
    const r = t.indexOf(Math.min(...t));
    const k = `${t[r]},${t[(r + 1) % 3]},${t[(r + 2) % 3]}`;
    s.set(k, (s.get(k) || 0) + 1);
  }
  return s;
}

// One primitive: the Draco decoding against the plain file's accessors.
function checkPrimitive(dm, d, p, pi, pbits, ubits, fail) {
  const prim = p.json.meshes[0].primitives[pi];

  const orig = { pos: accessor(p, prim.attributes.POSITION, Float32Array), uv: accessor(p, prim.attributes.TEXCOORD_0, Float32Array),
    idx: accessor(p, prim.indices, Uint32Array) };
  const dec = decodeDraco(dm, d, pi);
  const pa = p.json.accessors[prim.attributes.POSITION];
  const range = Math.max(...[0, 1, 2].map((k) => pa.max[k] - pa.min[k]));
  const pstep = range / ((1 << Number(pbits)) - 1);
  // the decoded values are float32: allow their rounding (2 ulp of the largest coordinate) on top of half a step
  const pulp = 2 * Math.max(...[0, 1, 2].map((k) => Math.max(Math.abs(pa.max[k]), Math.abs(pa.min[k])))) * 2 ** -23;
  const urange = [0, 1].map((k) => {
    let lo = Infinity, hi = -Infinity;
    for (let i = k; i < orig.uv.length; i += 2) { lo = Math.min(lo, orig.uv[i]); hi = Math.max(hi, orig.uv[i]); }
    return hi - lo;
  });
  const ustep = Math.max(...urange) / ((1 << Number(ubits)) - 1); // Draco's range: the largest component extent
  const m = matchVertices(orig, dec, pstep, ustep);
  const tris = orig.idx.length / 3, dtris = dec.faces.length / 3;
  console.log(`draco primitive ${pi}: ${dec.counts.points} points (accessor says ${dec.counts.accessorCount}), ${dtris} triangles ` +
    `(original ${tris}); max position error ${m.maxP.toExponential(3)} m (half step ${(pstep / 2).toExponential(3)}), ` +
    `max UV error ${m.maxU.toExponential(3)} (half step ${(ustep / 2).toExponential(3)}), unmatched ${m.unmatched}`);
  fail(dec.counts.points === dec.counts.accessorCount, 'decoded point count differs from the accessor count');
  fail(dec.counts.indexCount === dtris * 3, 'index accessor count differs from decoded triangles');
  fail(dtris === tris, 'triangle count not preserved');
  fail(m.unmatched === 0, `${m.unmatched} decoded vertices match no original vertex (position+UV)`);
  fail(m.maxP <= pstep / 2 + pulp, 'position error above half a quantisation step');
  fail(m.maxU <= ustep / 2 + 2 ** -22, 'UV error above half a quantisation step');
  // a mesh may hold separate vertices with identical position and UV (unwelded parts, as in ICT's model);
  // no decoder can tell them apart, so triangles are compared on one representative per such group
  const rep = new Int32Array(orig.pos.length / 3), first = new Map();
  for (let i = 0; i < rep.length; i++) {
    const k = `${orig.pos.subarray(i * 3, i * 3 + 3)}|${orig.uv.subarray(i * 2, i * 2 + 2)}`;
    if (!first.has(k)) first.set(k, i);
    rep[i] = first.get(k);
  }
  const a = triangleSet(orig.idx.map((i) => rep[i]), null), b = triangleSet(dec.faces, m.map.map((i) => (i < 0 ? -1 : rep[i])));
  let same = a.size === b.size;
  for (const [k, n] of a) if (b.get(k) !== n) same = false;
  fail(same, 'decoded triangles (mapped to original vertices) differ from the original triangles');
  // morph targets index the decoded vertices: a Draco file that carries them must decode in the original order
  const targets = (d.json.meshes[0].primitives[pi].targets || []).length;
  if (targets) {
    let moved = 0;
    for (let i = 0; i < rep.length; i++) if (m.map[i] < 0 || rep[m.map[i]] !== rep[i]) moved++;
    console.log(`draco: ${targets} morph targets, ${moved} decoded vertices out of the original order`);
    fail(moved === 0 && targets === (prim.targets || []).length, 'morph targets with reordered Draco vertices');
  }
}

async function main() {
  const [dracoPath, plainPath, pbits, ubits] = process.argv.slice(2);
  if (dracoPath === '-') process.exit((await validate(plainPath)) ? 0 : 1);
  let ok = (await validate(dracoPath)) & (await validate(plainPath));
  const d = parseGlb(fs.readFileSync(dracoPath)), p = parseGlb(fs.readFileSync(plainPath));
  const dm = await draco3d.createDecoderModule({});
  const fail = (cond, msg) => { if (!cond) { console.error('FAIL: ' + msg); ok = false; } };
  const np = p.json.meshes[0].primitives.length;
  fail(np === d.json.meshes[0].primitives.length, 'the Draco and plain files have different primitives');
  for (let pi = 0; pi < np; pi++) checkPrimitive(dm, d, p, pi, pbits, ubits, fail);
  process.exit(ok ? 0 : 1);
}

main().catch((e) => { console.error(e); process.exit(1); });
