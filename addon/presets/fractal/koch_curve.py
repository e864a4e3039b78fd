import bpy
ob = bpy.context.object

ob.unbound.kind = 'IFS'
ob.unbound.slice_offset = 0.0
ob.unbound.slice_rotation = (0.0, 0.0, 0.0)
ob.unbound.bailout = 4.0
ob.unbound.threshold_mode = 'FIXED'
ob.unbound.detail = 1.0
ob.unbound.step_factor = 1.0
ob.unbound.bisection_steps = 10
ob.unbound.normal_method = 'GRADIENT_DISTANCE'
ob.unbound.normal_alpha = 0.001
ob.unbound.normal_delta = 1.0
ob.unbound.color_mode = 'BASE'
ob.unbound.reflectivity = 0.0
ob.unbound.theta = 0.0
ob.unbound.ifs_depth = 6
ob.unbound.epsilon = 0.008
ob.unbound.color = (0.95, 0.7, 0.35)
ob.unbound.ifs_maps.clear()
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (-0.666666667, 0.0, 0.0)
item_sub_1.rotation = (0.0, 0.0, 0.0)
item_sub_1.scale = (0.333333333, 0.333333333, 0.333333333)
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (-0.166666667, 0.0, 0.288675135)
item_sub_1.rotation = (1.570796327, -1.047197551, 0.0)
item_sub_1.scale = (0.333333333, 0.333333333, 0.333333333)
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (0.166666667, 0.0, 0.288675135)
item_sub_1.rotation = (1.570796327, 1.047197551, 0.0)
item_sub_1.scale = (0.333333333, 0.333333333, 0.333333333)
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (0.666666667, 0.0, 0.0)
item_sub_1.rotation = (0.0, 0.0, 0.0)
item_sub_1.scale = (0.333333333, 0.333333333, 0.333333333)
ob.unbound.ifs_active_map = 0
