"""Scripts of test_proxy_blender.py: the Solid-mode proxy's surfaces (addon/proxy.py) as the draw
handler requests them, built on the worker thread, against the core and the analytic unit ball."""
import time

import bpy
import numpy as np


def _built(P, ob, timeout=120.0):
    """Requests the proxy of `ob` as the draw handler does, waits for the worker: the newest Job."""
    job = P.request(ob, bpy.context.evaluated_depsgraph_get())
    P.BUILDER.wait(timeout)
    return job


def _world(ob, vertices):
    m = np.array(ob.matrix_world, np.float64)
    return vertices.astype(np.float64) @ m[:3, :3].T + m[:3, 3]


def _core_mesh(mod, ob, resolution):
    """The same surface straight from the core (as Convert to Mesh asks for it)."""
    core = mod.utils.native()
    params = mod.export.object_parameters(ob, None, with_ramp=False)
    return core.mesh.extract(params, resolution=resolution, epsilon=mod.convert.surface_epsilon(ob))


def _same_as_core(mod, ob, surface, resolution):
    m = _core_mesh(mod, ob, resolution)
    return bool(np.array_equal(surface.vertices, m.vertices) and np.array_equal(surface.faces, m.faces))


def follows_the_fractal(S, mod, resolution):
    P = mod.proxy
    S.empty_scene()
    ob = S.add_fractal(mu=(0.0, 0.0, 0.0, 0.0))   # z^2: the filled Julia set is the unit ball
    ob.location = (1.0, 2.0, -0.5)
    ob.rotation_euler = (0.3, -0.2, 0.7)
    ob.scale = (2.0, 2.0, 2.0)
    ob.unbound.proxy_resolution = resolution
    out = dict(show_proxy_default=ob.unbound.show_proxy, resolution_default=type(ob.unbound).bl_rna.properties[
        "proxy_resolution"].default)
    status_before = P.status(ob)[0]

    started = time.perf_counter()
    ball = _built(P, ob)
    out["first_wait"] = time.perf_counter() - started
    s = P.shown_surface(ob)
    world = _world(ob, s.vertices)
    radius = np.linalg.norm(world - np.array(ob.location), axis=1) / 2.0   # back to object units
    outward = np.einsum("ij,ij->i", s.normals, s.vertices / np.linalg.norm(s.vertices, axis=1, keepdims=True))
    out["ball"] = dict(done=ball.done, error=ball.error, faces=len(s.faces), vertices=len(s.vertices),
                       edges=len(s.edges), cell=s.cell_size, radius_min=float(radius.min()),
                       radius_max=float(radius.max()), outward_min=float(outward.min()),
                       same_as_core=_same_as_core(mod, ob, s, resolution), seconds=s.seconds,
                       core_seconds=s.core_seconds, status=P.status(ob)[0], status_before=status_before,
                       euler=len(s.vertices) - len(s.edges) + len(s.faces))

    # What does not change the shape builds nothing: transform, colour, shading.
    builds = len(P.BUILDER.log)
    ob.location = (-3.0, 0.0, 0.0)
    ob.unbound.color = (0.2, 0.9, 0.1)
    ob.unbound.normal_method = 'ANALYTIC'
    again = _built(P, ob)
    out["unchanged"] = dict(same_job=again is ball, builds=len(P.BUILDER.log) - builds)

    # mu changes: a new surface, the core's, no longer a ball.
    ob.unbound.mu = (-0.2, 0.8, 0.0, 0.0)
    julia = _built(P, ob)
    s2 = P.shown_surface(ob)
    r2 = np.linalg.norm(s2.vertices, axis=1)
    out["julia"] = dict(new_job=julia is not ball, done=julia.done, faces=len(s2.faces),
                        same_as_core=_same_as_core(mod, ob, s2, resolution), radius_std=float(r2.std()),
                        radius_max=float(r2.max()), builds=len(P.BUILDER.log) - builds)

    # The resolution is the user's: twice the cells, half the cell size.
    ob.unbound.proxy_resolution = 2 * resolution
    finer = _built(P, ob)
    s3 = P.shown_surface(ob)
    out["finer"] = dict(new_job=finer is not julia, cell_ratio=s3.cell_size / s2.cell_size,
                        same_as_core=_same_as_core(mod, ob, s3, 2 * resolution))
    S.report(**out)


def cancels_and_reports(S, mod):
    """A slow surface is cancelled by the next change; bad settings give a message and no surface;
    a deleted object's surface goes."""
    P = mod.proxy
    S.empty_scene()
    ob = S.add_fractal()
    ob.unbound.kind = 'MANDELBULB'
    ob.unbound.max_iterations = 40
    ob.unbound.proxy_resolution = 384
    out = {}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    slow = P.request(ob, depsgraph)
    time.sleep(0.3)   # the worker is inside the core now
    changed = time.perf_counter()
    ob.unbound.proxy_resolution = 32
    quick = P.request(ob, depsgraph)
    P.BUILDER.wait(120)
    out["cancel"] = dict(slow_cancelled=slow.cancel.is_set(), slow_done=slow.done, slow_surface=slow.surface is not None,
                         quick_done=quick.done, shown_is_quick=P.BUILDER.ready(P.object_id(ob)) is quick,
                         seconds_after_change=time.perf_counter() - changed,
                         logged_keys=[k == slow.key for k, *_ in P.BUILDER.log])
    # What the slow one costs when it runs to the end, for comparison.
    t0 = time.perf_counter()
    full = mod.utils.native().mesh.extract(slow.params, resolution=slow.resolution)
    out["cancel"]["slow_full_seconds"] = time.perf_counter() - t0
    out["cancel"]["slow_full_faces"] = len(full.faces)
    del full

    # An IFS without maps: the add-on's message, nothing drawn (the old surface is not shown either).
    ob.unbound.kind = 'IFS'
    ob.unbound.ifs_maps.clear()
    job = P.request(ob, depsgraph)
    P.BUILDER.wait(30)
    out["no_maps"] = dict(error=job.error, shown=P.shown_surface(ob) is not None, status=list(P.status(ob)))
    # Settings the core refuses (a Mandelbox whose fixed radius is below its minimum radius).
    ob.unbound.kind = 'MANDELBOX'
    ob.unbound.min_radius, ob.unbound.fixed_radius = 1.5, 0.5
    job = _built(P, ob)
    out["core_refuses"] = dict(error=job.error, shown=P.shown_surface(ob) is not None, status=list(P.status(ob)))
    ob.unbound.fixed_radius = 2.0
    job = _built(P, ob)
    out["fixed"] = dict(error=job.error, shown=P.shown_surface(ob) is not None)

    ident = P.object_id(ob)
    bpy.data.objects.remove(ob)
    P.prune(interval=0.0)
    out["deleted"] = dict(latest=P.BUILDER.latest(ident) is not None, ready=P.BUILDER.ready(ident) is not None)
    S.report(**out)
