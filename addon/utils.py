"""Small helpers shared by the add-on's modules (imported first: no add-on imports here)."""
import bpy

ENGINE_ID = "UNBOUND"


def native():
    """The native core, or raise ImportError with a message a user can act on."""
    try:
        import unbound_core
    except ImportError as exc:  # the wheel failed to install or does not match this platform
        raise ImportError(
            "Unbound's native core could not be loaded (%s). Reinstall the extension for this "
            "platform from Edit > Preferences > Get Extensions" % exc) from exc
    return unbound_core


def is_fractal(ob):
    return ob is not None and ob.type == 'EMPTY' and ob.unbound.is_fractal


def compositor_tree(scene, create=False):
    """The scene's compositor node tree in 4.x (scene.node_tree) and 5.x
    (scene.compositing_node_group) alike; None if there is none and create is False."""
    if bpy.app.version >= (5, 0, 0):
        tree = scene.compositing_node_group
        if tree is None and create:
            tree = bpy.data.node_groups.new("Compositor", "CompositorNodeTree")
            tree.interface.new_socket("Image", in_out='OUTPUT', socket_type='NodeSocketColor')
            scene.compositing_node_group = tree
        return tree
    if create:
        scene.use_nodes = True
    return scene.node_tree if scene.use_nodes else None


def new_node_material(name):
    """A new material with its node tree (Principled BSDF and output). 4.x makes the tree on
    use_nodes; 5.x makes it with the material and deprecates use_nodes."""
    material = bpy.data.materials.new(name)
    if material.node_tree is None:
        material.use_nodes = True
    return material
