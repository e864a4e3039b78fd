import bpy
scene = bpy.context.scene

scene.unbound.samples = 4
scene.unbound.axle_light = 1.0
scene.unbound.use_scene_lights = True
scene.unbound.ambient = (0.06, 0.06, 0.07)
scene.unbound.shadows = 'HARD'
scene.unbound.use_gi = False
scene.unbound.ao_strength = 0.8
scene.unbound.ao_distance = 0.03
scene.unbound.ao_samples = 5
scene.unbound.reflection_depth = 0
scene.unbound.fog_density = 0.3
scene.unbound.fog_use_world = True
scene.unbound.fog_color = (0.5, 0.5, 0.5)
scene.unbound.glow_strength = 0.0
scene.unbound.glow_color = (0.4, 0.6, 1.0)
scene.unbound.use_sea = False
scene.unbound.sea_height = -1.0
scene.unbound.sea_wavelength = 0.25
scene.unbound.sea_amplitude = 0.01
scene.unbound.sea_color = (0.1, 0.25, 0.4)
scene.unbound.sea_reflectivity = 0.5
