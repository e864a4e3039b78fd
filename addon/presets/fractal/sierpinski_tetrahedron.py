import bpy
ob = bpy.context.object

ob.unbound.kind = 'IFS'
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
ob.unbound.ifs_depth = 7
ob.unbound.color = (0.9, 0.85, 0.75)
ob.unbound.ifs_maps.clear()
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (0.5, 0.5, 0.5)
item_sub_1.rotation = (0.0, 0.0, 0.0)
item_sub_1.scale = (0.5, 0.5, 0.5)
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (0.5, -0.5, -0.5)
item_sub_1.rotation = (0.0, 0.0, 0.0)
item_sub_1.scale = (0.5, 0.5, 0.5)
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (-0.5, 0.5, -0.5)
item_sub_1.rotation = (0.0, 0.0, 0.0)
item_sub_1.scale = (0.5, 0.5, 0.5)
item_sub_1 = ob.unbound.ifs_maps.add()
item_sub_1.location = (-0.5, -0.5, 0.5)
item_sub_1.rotation = (0.0, 0.0, 0.0)
item_sub_1.scale = (0.5, 0.5, 0.5)
ob.unbound.ifs_active_map = 0
