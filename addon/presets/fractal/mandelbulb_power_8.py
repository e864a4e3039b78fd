import bpy
ob = bpy.context.object

ob.unbound.kind = 'MANDELBULB'
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
ob.unbound.power = 8.0
ob.unbound.julia_mode = False
ob.unbound.julia_c = (0.0, 0.0, 0.0)
ob.unbound.max_iterations = 12
ob.unbound.color = (0.85, 0.7, 0.5)
