import bpy
ob = bpy.context.object

ob.unbound.kind = 'HYBRID'
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
ob.unbound.hybrid_steps.clear()
item = ob.unbound.hybrid_steps.add()
item.formula = 'MANDELBULB'
item.count = 1
item = ob.unbound.hybrid_steps.add()
item.formula = 'MANDELBOX'
item.count = 1
ob.unbound.power = 8.0
ob.unbound.box_scale = 2.0
ob.unbound.box_fold = 0.166666667
ob.unbound.min_radius = 0.0833333333
ob.unbound.fixed_radius = 0.166666667
ob.unbound.julia_mode = False
ob.unbound.julia_c = (0.0, 0.0, 0.0)
ob.unbound.max_iterations = 10
ob.unbound.color = (0.8, 0.65, 0.55)
