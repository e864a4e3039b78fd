import bpy
ob = bpy.context.object

ob.unbound.kind = 'JULIA_STACK'
ob.unbound.slice_offset = 0.0
ob.unbound.slice_rotation = (0.0, 0.0, 0.0)
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
ob.unbound.theta = 0.0
ob.unbound.path_mode = 'LINE'
ob.unbound.c_start = (-1.75, 0.0)
ob.unbound.c_end = (0.25, 0.0)
ob.unbound.stack_height = 2.0
ob.unbound.max_iterations = 32
ob.unbound.color = (0.85, 0.62, 0.4)
