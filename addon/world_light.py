"""The World as the core's environment light (issue 19): an equirectangular map of the World as
Blender itself evaluates it, so every world node tree (Sky Texture, Environment Texture with a
Mapping, any nodes) lights the fractals without a node re-implemented here.

A constant world (no nodes, or a Background node with unlinked Color and Strength) is a 1x1 map.
Any other world is baked: Cycles renders it through a panoramic equirectangular camera
(world_bake.py) in a Blender subprocess, since RenderEngine.render cannot start a render of its
own (Blender refuses a render while one runs), and an operator the user must remember would go
stale silently. The subprocess gets the World (and its images, node groups) in a temporary .blend
written by bpy.data.libraries.write. Maps are cached by a fingerprint of everything the bake reads
(node settings, unlinked socket values, links, images' files, resolution, samples): a world is
baked once per change. F12 bakes when needed; the viewport never waits for a bake (it would block
Blender's UI for seconds at each node edit): it uses a cached map, else the world's colour."""
import hashlib
import os
import pathlib
import subprocess
import sys
import tempfile

import bpy
import numpy as np

from .export import RenderError, world_surface_node

BAKE_SCRIPT = pathlib.Path(__file__).with_name("world_bake.py")
BAKE_TIMEOUT_S = 600
BAKE_VERSION = 1  # bump when the bake's output changes, so cached maps are not reused
_CACHE = {}  # fingerprint -> read-only float32 map
_CACHE_LIMIT = 8


class BakeError(RenderError):
    """The World could not be baked: the frame is not rendered (engine.render reports it)."""


def world_map(scene, bake=True):
    """The core's `world` keyword for `scene`: a float32 (h, w, 3) map, or None (no World, or the
    World's light turned off: missed rays then see the background colour, as before). bake=False:
    a non-constant World not baked yet gives None."""
    world = scene.world
    if world is None or not scene.unbound.use_world_light:
        return None
    constant = constant_radiance(world)
    if constant is not None:
        return np.array(constant, np.float32).reshape(1, 1, 3)
    s = scene.unbound
    key = fingerprint(world, s.world_resolution, s.world_bake_samples)
    if key in _CACHE or not bake:
        return _CACHE.get(key)
    baked = bake_world(world, s.world_resolution, s.world_bake_samples)
    if len(_CACHE) >= _CACHE_LIMIT:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = baked
    return baked


def constant_radiance(world):
    """RGB of a World that is one colour everywhere, else None."""
    if not (world.use_nodes and world.node_tree):
        return tuple(world.color)
    bg = world_surface_node(world)
    if bg is None:
        return (0.0, 0.0, 0.0)  # what Cycles shows: no surface shader, a black world
    if bg.type != 'BACKGROUND' or bg.mute or bg.inputs["Color"].is_linked or bg.inputs["Strength"].is_linked:
        return None
    color, strength = bg.inputs["Color"].default_value, bg.inputs["Strength"].default_value
    return tuple(c * strength for c in color[:3])


# ---------------------------------------------------------------------------- fingerprint

# Node properties that do not change what the node computes.
_INERT = {"rna_type", "name", "label", "location", "width", "width_hidden", "height", "dimensions", "select",
          "show_options", "show_preview", "hide", "show_texture", "use_custom_color", "color", "parent",
          "internal_links", "inputs", "outputs", "id_data", "bl_idname", "bl_label", "bl_description",
          "bl_icon", "bl_static_type", "bl_width_default", "bl_width_min", "bl_width_max",
          "bl_height_default", "bl_height_min", "bl_height_max", "type", "is_active_output", "warning_propagation"}


def fingerprint(world, resolution, samples):
    h = hashlib.sha256()
    h.update(repr((BAKE_VERSION, resolution, samples, world.use_nodes, tuple(world.color))).encode())
    if world.use_nodes and world.node_tree:
        _hash_tree(world.node_tree, h, 0)
    return h.hexdigest()


def _hash_tree(tree, h, depth):
    for node in sorted(tree.nodes, key=lambda n: n.name):
        h.update(("node %s %s %s" % (node.name, node.bl_idname, getattr(node, "mute", False))).encode())
        if node.type == 'OUTPUT_WORLD':
            h.update(repr(node.is_active_output).encode())
        for prop in node.bl_rna.properties:
            if prop.identifier not in _INERT:
                _hash_value(getattr(node, prop.identifier, None), h, depth + 1)
        for sock in node.inputs:
            h.update(("in %s %s" % (sock.identifier, sock.is_linked)).encode())
            if not sock.is_linked and hasattr(sock, "default_value"):
                _hash_value(sock.default_value, h, depth + 1)
    for link in tree.links:
        h.update(("link %s.%s>%s.%s %s %s" % (link.from_node.name, link.from_socket.identifier, link.to_node.name,
                                               link.to_socket.identifier, link.is_valid, link.is_muted)).encode())


def _hash_value(value, h, depth):
    if depth > 6:
        return
    if isinstance(value, bpy.types.Image):
        _hash_image(value, h)
    elif isinstance(value, bpy.types.NodeTree):
        h.update(("group %s" % value.name).encode())
        _hash_tree(value, h, depth + 1)
    elif isinstance(value, bpy.types.Object):
        h.update(repr([tuple(row) for row in value.matrix_world]).encode())
    elif isinstance(value, bpy.types.ID):
        h.update(("id %s" % value.name).encode())
    elif isinstance(value, bpy.types.bpy_struct):
        for prop in value.bl_rna.properties:
            if prop.identifier not in _INERT and prop.type != 'COLLECTION':
                _hash_value(getattr(value, prop.identifier, None), h, depth + 1)
    elif hasattr(value, "__len__") and not isinstance(value, str):
        h.update(repr([v if isinstance(v, (int, float, bool, str)) else tuple(v) for v in value]).encode())
    else:
        h.update(repr(value).encode())


def _hash_image(image, h):
    path = bpy.path.abspath(image.filepath, library=image.library) if image.filepath else ""
    stat = os.stat(path) if path and os.path.isfile(path) else None
    h.update(repr((image.name, image.source, path, stat and (stat.st_size, stat.st_mtime_ns),
                   image.packed_file and image.packed_file.size, image.colorspace_settings.name,
                   image.alpha_mode, tuple(image.size), image.is_dirty, image.generated_type,
                   tuple(image.generated_color), image.use_generated_float)).encode())
    if image.is_dirty:
        # Painted in this session: only its pixels say what it holds (and the bake, which reads
        # the saved .blend, sees them only if packed). An unpainted generated image is its
        # settings above (a 2048 x 1024 one's pixels took 60 ms to read, at every viewport draw).
        pixels = np.empty(len(image.pixels), np.float32)
        image.pixels.foreach_get(pixels)
        h.update(pixels.tobytes())


# ---------------------------------------------------------------------------- bake

def bake_command(script_args):
    """How to run world_bake.py: Blender's own binary in the background, or, under the bpy module
    (bpy.app.binary_path empty), this Python, which imports bpy."""
    blender = bpy.app.binary_path
    if blender and os.path.basename(blender).lower().startswith("blender"):
        return [blender, "-b", "--factory-startup", "-noaudio", "--python", str(BAKE_SCRIPT), "--"] + script_args
    return [sys.executable, str(BAKE_SCRIPT), "--"] + script_args


def bake_world(world, resolution, samples):
    """The World rendered by Cycles into a (resolution / 2, resolution, 3) map (world_bake.py)."""
    with tempfile.TemporaryDirectory(prefix="unbound_world_") as tmp:
        blend = os.path.join(tmp, "world.blend")
        out = os.path.join(tmp, "world.npy")
        # Images painted or generated in this session reach the subprocess only when packed.
        bpy.data.libraries.write(blend, {world}, path_remap='ABSOLUTE', fake_user=True, compress=False)
        cmd = bake_command([blend, world.name, out, str(int(resolution)), str(int(samples))])
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=BAKE_TIMEOUT_S, cwd=tmp)
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise BakeError("baking the World '%s' with Cycles failed: %s" % (world.name, exc)) from None
        if proc.returncode != 0 or not os.path.isfile(out):
            tail = (proc.stdout + proc.stderr).strip().splitlines()[-6:]
            raise BakeError("baking the World '%s' with Cycles failed (exit code %d): %s"
                            % (world.name, proc.returncode, " | ".join(tail)))
        baked = np.load(out)
    expected = (int(resolution) // 2, int(resolution), 3)
    if baked.shape != expected or baked.dtype != np.float32:
        raise BakeError("baking the World '%s' gave a %s %s map, not %s float32"
                        % (world.name, baked.shape, baked.dtype, expected))
    # Node trees can emit negative or non-finite values (math nodes): no light comes from those.
    baked = np.nan_to_num(baked, nan=0.0, posinf=0.0, neginf=0.0)
    np.clip(baked, 0.0, 1e12, out=baked)
    baked.setflags(write=False)
    return baked


def clear_cache():
    _CACHE.clear()
