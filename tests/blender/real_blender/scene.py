"""Shared by the scripts that run inside the real `blender`: the startup scene emptied, with a
camera looking at the origin from (0.4, -3, 0.9), as tests/blender/bpy_session.py sets it up."""
import bpy
from mathutils import Vector


def camera_scene():
    scene = bpy.context.scene
    for ob in list(scene.objects):  # the startup scene's cube, light and camera
        bpy.data.objects.remove(ob)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (0.4, -3.0, 0.9)
    cam.rotation_euler = (Vector((0, 0, 0)) - cam.location).to_track_quat('-Z', 'Y').to_euler()
    scene.camera = cam
    return scene
