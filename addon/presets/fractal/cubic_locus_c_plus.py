import bpy
ob = bpy.context.object

ob.unbound.kind = 'CUBIC_LOCUS'
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
ob.unbound.cubic_component = 'PLUS'
ob.unbound.extent = 1.5
ob.unbound.max_iterations = 24
ob.unbound.color = (0.55, 0.6, 0.9)
