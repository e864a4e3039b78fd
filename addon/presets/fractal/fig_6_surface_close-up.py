import bpy
ob = bpy.context.object

ob.unbound.kind = 'QUATERNION_JULIA'
ob.unbound.slice_offset = 0.0
ob.unbound.slice_rotation = (0.0, 0.0, 0.0)
ob.unbound.bailout = 4.0
ob.unbound.threshold_mode = 'PIXEL'
ob.unbound.detail = 2.0
ob.unbound.step_factor = 1.0
ob.unbound.bisection_steps = 10
ob.unbound.normal_method = 'ANALYTIC'
ob.unbound.normal_alpha = 0.001
ob.unbound.normal_delta = 1.0
ob.unbound.color_mode = 'BASE'
ob.unbound.reflectivity = 0.0
ob.unbound.theta = 0.0
ob.unbound.mu = (-0.2, 0.8, 0.0, 0.0)
ob.unbound.max_iterations = 40
ob.unbound.color = (0.8, 0.7, 0.6)
