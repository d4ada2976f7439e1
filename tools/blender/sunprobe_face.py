# SPDX-License-Identifier: MIT
"""Loads a `sunprobe export --no-draco` face into Blender, set up to look as sunprobe renders it.

    blender --python tools/blender/sunprobe_face.py -- FACE.glb

Imports the .glb (Debian's Blender cannot decode Draco: export with --no-draco) and applies what glTF
cannot carry (export/EXPORT.md, "Photometry"): the Standard view transform, the film exposure that
undoes the export's lux per fit unit, the environment map `extras.sunprobe.environment_map.uri` as the
world at 1/683 strength (the importer's lm/W), the keyframe 0 camera as the scene camera and its image
size as the render resolution. The sun keeps its physical lux (the importer divides by 683).
"""
import json
import os
import struct
import sys

import bpy

GLB_MAGIC = 0x46546C67
JSON_CHUNK = 0x4E4F534A


def read_glb_json(path):
    """The JSON chunk of a .glb (the importer keeps no asset extras, so they are read here)."""
    with open(path, "rb") as f:
        head = f.read(20)
        if len(head) < 20:
            raise ValueError(f"{path}: not a .glb (too short)")
        magic, _version, _length, clen, ctype = struct.unpack("<5I", head)
        if magic != GLB_MAGIC or ctype != JSON_CHUNK:
            raise ValueError(f"{path}: not a .glb (magic or first chunk)")
        return json.loads(f.read(clen))


def clear_scene():
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob, do_unlink=True)


def set_world(scene, hdr_path, strength):
    world = bpy.data.worlds.new("sunprobe environment")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    bg = nodes.get("Background")
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(hdr_path)
    env.interpolation = "Closest"  # the 16 x 32 map's texels are the fit's unknowns
    links.new(env.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = strength
    scene.world = world


def wire_specular(material, factor):
    """Blender 3.4's importer parks KHR_materials_specular's texture in an unconnected group and leaves
    the Principled BSDF at Specular 0.5 everywhere; glTF's strength 1 (ior 1.5, F0 0.04) is Specular 0.5."""
    tree = material.node_tree
    bsdf = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        return
    link = next((l for l in tree.links if l.to_node.type == "GROUP" and l.to_socket.name == "Specular"), None)
    scale = tree.nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = 0.5 * factor
    if link is not None:
        tree.links.new(link.from_socket, scale.inputs[0])
    else:
        scale.inputs[0].default_value = 1.0
    tree.links.new(scale.outputs[0], bsdf.inputs["Specular"])


def load(glb_path):
    """Imports and sets up the scene; returns the glTF JSON (for callers that check it)."""
    gltf = read_glb_json(glb_path)
    if any(e == "KHR_draco_mesh_compression" for e in gltf.get("extensionsRequired", [])):
        raise ValueError(f"{glb_path}: Draco-compressed; Debian's Blender cannot decode it: "
                         "export with --no-draco")
    extras = gltf.get("asset", {}).get("extras", {}).get("sunprobe", {})
    photometry = extras.get("photometry", {})
    clear_scene()
    # SMOOTH: the default shading path fails with NumPy >= 1.24 (np.bool) in Blender 3.4's importer
    bpy.ops.import_scene.gltf(filepath=glb_path, import_shading="SMOOTH")
    for mat in gltf.get("materials", []):
        ext = mat.get("extensions", {}).get("KHR_materials_specular")
        if ext is not None and mat.get("name") in bpy.data.materials:
            wire_specular(bpy.data.materials[mat["name"]], ext.get("specularFactor", 1.0))
    scene = bpy.context.scene
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = photometry.get("blender_film_exposure_ev", 0.0)
    env = extras.get("environment_map", {}).get("uri")
    if env:
        set_world(scene, os.path.join(os.path.dirname(os.path.abspath(glb_path)), env),
                  photometry.get("blender_world_strength_for_env", 1.0 / 683.0))
    cams = [ob for ob in scene.objects if ob.type == "CAMERA"]
    if cams:
        scene.camera = cams[0]
        size = (gltf.get("cameras", [{}])[0].get("extras", {}).get("sunprobe", {}))
        if "image_width" in size and "image_height" in size:
            scene.render.resolution_x, scene.render.resolution_y = size["image_width"], size["image_height"]
            scene.render.resolution_percentage = 100
            # the importer fits the sensor vertically; a non-square image keeps yfov that way
            cams[0].data.sensor_fit = "VERTICAL"
    return gltf


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(args) != 1:
        print("usage: blender --python sunprobe_face.py -- FACE.glb", file=sys.stderr)
        sys.exit(1)
    load(args[0])
