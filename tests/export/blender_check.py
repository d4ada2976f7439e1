# SPDX-License-Identifier: MIT
"""Blender side of tests/export/test_blender.sh (run inside `blender -b --python`).

    blender -b --factory-startup --python blender_check.py -- FACE.glb OUTDIR SAMPLES

Loads the face with tools/blender/sunprobe_face.py (the user's path), checks what the importer made
against the .glb's JSON (vertex/triangle counts, materials and their textures, shape key names, the
sun's W/m2, the camera), renders one Cycles frame from the glTF camera and writes OUTDIR/mask.png
(alpha > 0.5) and prints `blender: mean_luminance L` (linear Rec. 709 luminance over the mask, after
the scene's film exposure), then the same frame with Eevee (`blender: eevee_mean_luminance L`; in
background mode Blender falls back to surfaceless EGL, Mesa's software OpenGL on a machine without a
GPU). Exit 1 on a failed check.
"""
import os
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
sys.path.insert(0, os.environ["SUNPROBE_BLENDER_TOOLS"])
import sunprobe_face  # noqa: E402 (path set above)

glb, outdir, samples = args[0], args[1], int(args[2])
gltf = sunprobe_face.load(glb)
scene = bpy.context.scene
failures = []


def check(ok, what):
    print(("ok: " if ok else "FAIL: ") + what)
    if not ok:
        failures.append(what)


prims = gltf["meshes"][0]["primitives"]  # skin, then eyes and mouth where the face model has them
n_vert = sum(gltf["accessors"][p["attributes"]["POSITION"]]["count"] for p in prims)
n_tri = sum(gltf["accessors"][p["indices"]]["count"] // 3 for p in prims)
meshes = [ob for ob in scene.objects if ob.type == "MESH"]
check(len(meshes) == 1, f"one mesh object (got {len(meshes)})")
me = meshes[0].data
check(len(me.vertices) == n_vert, f"vertices {len(me.vertices)} == accessor count {n_vert}")
check(len(me.polygons) == n_tri and all(len(p.vertices) == 3 for p in me.polygons),
      f"triangles {len(me.polygons)} == {n_tri}")
mats = [m for m in me.materials if m]
check(len(mats) == len(gltf["materials"]), f"materials {len(mats)} == {len(gltf['materials'])}")
for p in prims:  # each primitive's triangles carry its own material
    name = gltf["materials"][p["material"]]["name"]
    idx = [i for i, m in enumerate(me.materials) if m and m.name == name]
    got = sum(1 for poly in me.polygons if poly.material_index in idx)
    want = gltf["accessors"][p["indices"]]["count"] // 3
    check(got == want, f"material {name} on {got} triangles == its primitive's {want}")
used = {n.image.name for m in mats for n in m.node_tree.nodes if n.type == "TEX_IMAGE" and n.image}
want = {im.get("name", f"Image_{i}") for i, im in enumerate(gltf.get("images", []))}
check(want <= used, f"the material uses the glTF's images {sorted(want)} (Blender's: {sorted(used)})")
for gm in gltf["materials"]:
    tex = "specularTexture" in gm.get("extensions", {}).get("KHR_materials_specular", {})
    bsdf = next(n for n in bpy.data.materials[gm["name"]].node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    src = [l.from_node for l in bsdf.inputs["Specular"].links]
    fed = bool(src) and any(l.from_node.type == "TEX_IMAGE" for l in src[0].inputs[0].links)
    check(fed == tex, f"material {gm['name']}: Principled Specular from the specular texture: {fed}")
want_keys = gltf["meshes"][0].get("extras", {}).get("targetNames", [])
keys = [k.name for k in me.shape_keys.key_blocks[1:]] if me.shape_keys else []
check(keys == want_keys, f"shape keys {keys} == targetNames {want_keys}")
for k in range(len(keys) if prims[0].get("targets") else 0):
    accs = [gltf["accessors"][p["targets"][k]["POSITION"]] for p in prims]
    want = max(abs(x) for acc in accs for x in acc["min"] + acc["max"])
    basis, key = me.shape_keys.key_blocks[0].data, me.shape_keys.key_blocks[k + 1].data
    got = max(abs(key[i].co[a] - basis[i].co[a]) for i in range(len(basis)) for a in range(3))
    check(abs(got - want) <= 1e-6 + 1e-4 * want, f"shape key {keys[k]} moves up to {got:.5f} m (glTF {want:.5f})")
suns = [ob for ob in scene.objects if ob.type == "LIGHT" and ob.data.type == "SUN"]
lights = gltf.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
if lights:
    lux = lights[0]["intensity"]
    check(len(suns) == 1 and abs(suns[0].data.energy - lux / 683.0) < 1e-3 * lux / 683.0,
          f"one sun of {lux / 683.0:.4g} W/m2 ({lux:.6g} lux / 683)")
else:
    check(not suns, "no sun (the export has none)")
check(scene.camera is not None and scene.camera.type == "CAMERA", "the glTF camera is the scene camera")


def render_face(engine, name):
    """Renders the scene with `engine` to OUTDIR/name; its size, the alpha > 0.5 pixels' mask and mean luminance."""
    scene.render.engine = engine
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.filepath = os.path.join(outdir, name)
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(scene.render.filepath)
    w, h = img.size
    px = list(img.pixels)  # linear scene light, bottom row first; EXR gets no view transform
    gain = 2.0 ** scene.view_settings.exposure
    mask = [0.0] * (w * h * 4)
    total, n = 0.0, 0
    for i in range(0, w * h * 4, 4):
        if px[i + 3] > 0.5:
            total += gain * (0.2126 * px[i] + 0.7152 * px[i + 1] + 0.0722 * px[i + 2]) / px[i + 3]
            n += 1
            mask[i:i + 4] = (1.0, 1.0, 1.0, 1.0)
        else:
            mask[i + 3] = 1.0
    return w, h, n, mask, total / max(n, 1)


scene.cycles.device = "CPU"
scene.cycles.samples = samples
scene.cycles.use_denoising = False
scene.eevee.taa_render_samples = samples
print(f"blender: exposure {scene.view_settings.exposure:.3f} EV")
w, h, n, mask, mean = render_face("CYCLES", "render.exr")
_, _, en, _, emean = render_face("BLENDER_EEVEE", "eevee.exr")
out = bpy.data.images.new("mask", w, h)
out.pixels = mask
scene.view_settings.exposure = 0.0  # save_render applies the view transform; the mask is 0 or 1
settings = scene.render.image_settings  # stored (uncompressed) PNG: readable by a build without zlib
settings.file_format, settings.color_mode, settings.color_depth, settings.compression = "PNG", "RGB", "8", 0
out.save_render(os.path.join(outdir, "mask.png"), scene=scene)

print(f"blender: {w}x{h}, {n} face pixels (Eevee: {en})")
print(f"blender: mean_luminance {mean:.6g}")
print(f"blender: eevee_mean_luminance {emean:.6g}")
check(n > 0, "the render shows the face")
check(en > 0.9 * n and en < 1.1 * n, "Eevee shows the face as Cycles does (face pixels within 10 %)")
sys.exit(1 if failures else 0)
