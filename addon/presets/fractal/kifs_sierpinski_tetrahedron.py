import bpy
ob = bpy.context.object

ob.unbound.kind = 'KIFS'
ob.unbound.bailout = 4.0
ob.unbound.threshold_mode = 'PIXEL'
ob.unbound.detail = 1.0
ob.unbound.step_factor = 1.0
ob.unbound.bisection_steps = 10
ob.unbound.normal_method = 'GRADIENT_DISTANCE'
ob.unbound.normal_alpha = 0.001
ob.unbound.normal_delta = 1.0
ob.unbound.color_mode = 'BASE'
ob.unbound.reflectivity = 0.0
ob.unbound.kifs_planes.clear()
item = ob.unbound.kifs_planes.add()
item.normal = (1.0, 1.0, 0.0)
item.offset = 0.0
item = ob.unbound.kifs_planes.add()
item.normal = (1.0, 0.0, 1.0)
item.offset = 0.0
item = ob.unbound.kifs_planes.add()
item.normal = (0.0, 1.0, 1.0)
item.offset = 0.0
ob.unbound.kifs_scale = 2.0
ob.unbound.kifs_offset = (1.0, 1.0, 1.0)
ob.unbound.kifs_rotation = (0.0, 0.0, 0.0)
ob.unbound.kifs_shape = 'TETRAHEDRON'
ob.unbound.kifs_size = 1.0
ob.unbound.max_iterations = 10
ob.unbound.color = (0.85, 0.6, 0.4)
