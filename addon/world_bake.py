"""Bakes a World into an equirectangular map with Cycles; run in a Blender subprocess by
world_light.py (never imported by the add-on):

    blender -b --factory-startup --python world_bake.py -- WORLD.blend NAME OUT.npy WIDTH SAMPLES
    python world_bake.py -- ...   (under the bpy module)

It appends World NAME from WORLD.blend into an empty scene and renders it through a panoramic
equirectangular camera turned (90, 0, -90) degrees (XYZ Euler), which puts image point (u, v) on
the direction of Cycles' Environment Texture mapping, u = atan2(-y, x) / 2 pi + 0.5, v = latitude /
pi + 0.5 (measured: tests/blender/test_world_light_blender.py). A one-pixel box filter makes each
texel the World's mean over the texel, what a piecewise-constant map stands for. The map goes to
OUT.npy as float32 (WIDTH / 2, WIDTH, 3), row 0 at the nadir (Blender's image order)."""
import math
import os
import sys

import bpy
import numpy as np


def main(blend, name, out, width, samples):
    bpy.ops.wm.read_homefile(use_empty=True)
    with bpy.data.libraries.load(blend, link=False) as (source, target):
        if name not in source.worlds:
            raise SystemExit("world_bake: no World '%s' in %s" % (name, blend))
        target.worlds = [name]
    scene = bpy.context.scene
    scene.world = target.worlds[0]
    render = scene.render
    render.engine = 'CYCLES'
    render.resolution_x, render.resolution_y, render.resolution_percentage = width, width // 2, 100
    render.film_transparent = False
    render.use_compositing = render.use_sequencer = False
    render.filter_size = 1.0
    scene.cycles.device = 'CPU'
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = 'BOX'
    scene.cycles.seed = 0
    scene.view_settings.view_transform = 'Standard'
    scene.view_settings.look = 'None'
    scene.view_settings.exposure, scene.view_settings.gamma = 0.0, 1.0
    cam_data = bpy.data.cameras.new("UnboundWorldBake")
    cam_data.type = 'PANO'
    if hasattr(cam_data, "panorama_type"):  # Blender 4.x; earlier: cam_data.cycles
        cam_data.panorama_type = 'EQUIRECTANGULAR'
    else:
        cam_data.cycles.panorama_type = 'EQUIRECTANGULAR'
    cam = bpy.data.objects.new("UnboundWorldBake", cam_data)
    scene.collection.objects.link(cam)
    cam.rotation_euler = (math.pi / 2, 0.0, -math.pi / 2)
    scene.camera = cam
    settings = render.image_settings
    settings.file_format, settings.color_depth, settings.color_mode = 'OPEN_EXR', '32', 'RGB'
    exr = os.path.splitext(out)[0] + ".exr"
    render.filepath = exr
    bpy.ops.render.render(write_still=True, scene=scene.name)
    image = bpy.data.images.load(exr)
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    channels = image.channels
    np.save(out, np.ascontiguousarray(pixels.reshape(width // 2, width, channels)[..., :3]))


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:]
    main(args[0], args[1], args[2], int(args[3]), int(args[4]))
