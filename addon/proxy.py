"""The fractal's proxy in Solid, Material Preview and Wireframe shading: a low-resolution surface
from the core's mesh extraction (native/src/mesh.c, as Convert to Mesh), drawn with the `gpu`
module in place of the bare empty, so scenes can be laid out without Rendered mode.

Threads: the draw handler runs on Blender's main thread. It reads each visible fractal's
parameters (export.object_parameters, about 50 microseconds) and hands a Job to the Builder when
the shape changed; the Builder's worker thread runs the core, which releases the GIL and polls
the job's cancel flag, so the UI never waits for a surface. Until the new surface is ready the
last one stays on screen. A main-thread timer tags the 3D views for a redraw when one is ready:
the worker touches nothing of bpy.

Jobs are keyed by what changes the shape: the object's core parameters but its appearance
(colour, normals, colouring), the resolution and the surface's epsilon. A transform only moves
the surface (the shader applies the object's matrix), and a colour only recolours it."""
import collections
import threading
import time

import bpy
import numpy as np

from . import convert, export, utils

# Object keys that only change how the surface looks, never where it is.
APPEARANCE_KEYS = frozenset({"name", "color", "normal_method", "normal_alpha", "normal_delta", "reflectivity",
                             "color_mode", "ramp_scale", "ramp_offset", "color_ramp"})
# Shading types that draw the proxy (Rendered shows the render itself).
PROXY_SHADING = frozenset({'SOLID', 'MATERIAL', 'WIREFRAME'})
# How often the main thread looks for finished surfaces while the worker is busy (seconds).
POLL_INTERVAL = 0.05

# A surface in object space: vertices and unit normals (n, 3) float32, triangle corners (m, 3)
# and unique edges (k, 2) uint32, the lattice cell size, the core's seconds and the whole job's.
Surface = collections.namedtuple("Surface", "vertices normals faces edges cell_size core_seconds seconds")


class Job:
    """One surface to build: the core's object dict, resolution and epsilon, and its cancel flag."""
    __slots__ = ("key", "params", "resolution", "epsilon", "cancel", "surface", "error", "done")

    def __init__(self, key, params, resolution, epsilon):
        self.key, self.params, self.resolution, self.epsilon = key, params, resolution, epsilon
        self.cancel = threading.Event()
        self.surface = self.error = None
        self.done = False


def shape_key(params, resolution, epsilon):
    """Equal for parameters that give the same surface (repr: floats print exactly)."""
    shape = {k: v for k, v in params.items() if k not in APPEARANCE_KEYS}
    return repr((sorted(shape.items()), int(resolution), float(epsilon)))


def vertex_normals(vertices, faces):
    """Area-weighted unit normals at the vertices (faces counter-clockwise from outside)."""
    corners = vertices[faces]
    face_normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals = np.zeros_like(vertices)
    for c in range(3):
        for axis in range(3):
            normals[:, axis] += np.bincount(faces[:, c], face_normals[:, axis], len(vertices)).astype(np.float32)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return (normals / np.maximum(length, 1e-30)).astype(np.float32)


def unique_edges(faces):
    """Each edge of the triangles once, as vertex pairs (lower index first)."""
    pairs = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]).astype(np.int64)
    pairs.sort(axis=1)
    packed = np.unique(pairs[:, 0] << 32 | pairs[:, 1])
    return np.stack([packed >> 32, packed & 0xFFFFFFFF], axis=1).astype(np.uint32)


def build_surface(job, threads=0):
    """The job's surface from the core; None when the job was cancelled."""
    started = time.perf_counter()
    mesh = utils.native().mesh.extract(job.params, resolution=job.resolution, epsilon=job.epsilon,
                                       threads=threads, cancel=job.cancel)
    if mesh.stats["cancelled"] or job.cancel.is_set():
        return None
    faces = mesh.faces.astype(np.uint32)
    return Surface(mesh.vertices, vertex_normals(mesh.vertices, mesh.faces), faces, unique_edges(faces),
                   mesh.stats["cell_size"], mesh.stats["seconds"], time.perf_counter() - started)


class Builder:
    """Surfaces of the fractals, built on one worker thread, the newest request of each object
    first come, first served; the last finished surface of each object is kept for drawing.

    request() returns at once: a changed key cancels the object's job in flight."""

    def __init__(self, on_ready=None):
        self._on_ready = on_ready
        self._cond = threading.Condition()
        self._latest = {}       # object -> newest Job
        self._ready = {}        # object -> newest Job with a surface
        self._queue = collections.OrderedDict()  # object -> Job waiting for the worker
        self._running = None
        self._stopping = False
        self.finished = 0       # jobs finished (surface or error), for the redraw timer and tests
        # (key, seconds, core seconds, vertices, faces) of each surface built, for tests and the benchmark.
        self.log = collections.deque(maxlen=1024)
        self._thread = threading.Thread(target=self._run, name="Unbound proxy", daemon=True)
        self._thread.start()

    # Main thread ---------------------------------------------------------------------------
    def request(self, ident, key, make_job):
        """The object's newest Job; make_job() builds one when `key` differs from it."""
        with self._cond:
            job = self._latest.get(ident)
            if job is not None and job.key == key:
                return job
            if job is not None:
                job.cancel.set()
            job = self._latest[ident] = make_job()
            self._queue.pop(ident, None)
            if not job.done:   # a job born failed (unreadable parameters) is never built
                self._queue[ident] = job
                self._cond.notify_all()
            return job

    def ready(self, ident):
        """The newest Job of the object that has a surface, or None."""
        with self._cond:
            return self._ready.get(ident)

    def latest(self, ident):
        with self._cond:
            return self._latest.get(ident)

    def busy(self):
        with self._cond:
            return bool(self._queue) or self._running is not None

    def wait(self, timeout=60.0):
        """Blocks until every request so far is done."""
        deadline = time.perf_counter() + timeout
        with self._cond:
            while self._queue or self._running is not None:
                left = deadline - time.perf_counter()
                if left <= 0:
                    raise TimeoutError("the proxy surfaces were not built within %.0f s" % timeout)
                self._cond.wait(left)

    def forget(self, keep):
        """Drops the objects not in `keep` (deleted ones), cancelling their jobs."""
        with self._cond:
            for ident in [i for i in self._latest if i not in keep]:
                self._latest.pop(ident).cancel.set()
                self._ready.pop(ident, None)
                self._queue.pop(ident, None)

    def stop(self):
        with self._cond:
            self._stopping = True
            for job in self._latest.values():
                job.cancel.set()
            self._cond.notify_all()
        if threading.current_thread() is not self._thread:
            self._thread.join(10.0)

    # Worker thread -------------------------------------------------------------------------
    def _run(self):
        while True:
            with self._cond:
                while not self._stopping and not self._queue:
                    self._cond.wait()
                if self._stopping:
                    return
                ident, job = self._queue.popitem(last=False)
                self._running = job
            surface = error = None
            try:
                surface = build_surface(job)
            except (ValueError, TypeError, ImportError, MemoryError) as exc:  # the core's answers to bad input
                error = str(exc)
            except Exception as exc:  # noqa: BLE001 - reported, and the worker lives on
                error = "%s: %s" % (type(exc).__name__, exc)
            with self._cond:
                self._running = None
                if not job.cancel.is_set():
                    job.surface, job.error, job.done = surface, error, True
                    if surface is not None and self._latest.get(ident) is job:
                        self._ready[ident] = job
                        self.log.append((job.key, surface.seconds, surface.core_seconds, len(surface.vertices),
                                         len(surface.faces)))
                    self.finished += 1
                self._cond.notify_all()
            if self._on_ready is not None:
                self._on_ready()


# The add-on's one Builder (created at register) and what the main thread knows of it --------

BUILDER = None
_seen_finished = 0
_errors_printed = set()


def object_id(ob):
    """Stable for the object's lifetime in this session, unlike its name."""
    return ob.session_uid


def request(ob, depsgraph=None):
    """Requests the surface of fractal `ob` (its current shape and proxy resolution) and returns
    its newest Job; an error Job when its parameters cannot be read."""
    try:
        params = export.object_parameters(ob, depsgraph, with_ramp=False)
        epsilon = convert.surface_epsilon(ob)
    except (export.RenderError, ImportError, ValueError, TypeError) as exc:
        params, epsilon, failure = None, 0.0, str(exc)
    else:
        failure = None
    resolution = ob.unbound.proxy_resolution
    key = repr(("error", failure)) if failure else shape_key(params, resolution, epsilon)

    def make_job():
        job = Job(key, params, resolution, epsilon)
        if failure:
            job.cancel.set()   # never built: the worker drops it
            job.error, job.done = failure, True
        return job

    job = BUILDER.request(object_id(ob), key, make_job)
    if not job.done:
        _watch()
    return job


def shown_surface(ob):
    """The surface drawn for `ob` now: the newest built, unless its newest request failed."""
    ident = object_id(ob)
    latest = BUILDER.latest(ident)
    if latest is not None and latest.error:
        return None
    job = BUILDER.ready(ident)
    return job.surface if job is not None else None


def _watch():
    if not bpy.app.timers.is_registered(_poll):
        bpy.app.timers.register(_poll, first_interval=POLL_INTERVAL)


def _poll():
    """Main-thread timer while the worker is busy: redraw the 3D views when a surface is ready."""
    global _seen_finished
    if BUILDER is None:
        return None
    if BUILDER.finished != _seen_finished:
        _seen_finished = BUILDER.finished
        tag_redraw_views()
    return POLL_INTERVAL if BUILDER.busy() or BUILDER.finished != _seen_finished else None


def tag_redraw_views():
    wm = bpy.context.window_manager
    for window in (wm.windows if wm else ()):
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()


# Drawing ---------------------------------------------------------------------------------

VERTEX_SOURCE = """
void main()
{
    gl_Position = ModelViewProjectionMatrix * vec4(pos, 1.0);
    /* A headlight, as Blender's studio lighting is fixed to the view: the view axis in object
       space (exact for rotation and uniform scale). Both sides lit. */
    float facing = abs(dot(normalize(nor), headlight.xyz));
    shade = 0.3 + 0.7 * facing;
}
"""
FRAGMENT_SOURCE = """
void main()
{
    fragColor = vec4(color.rgb * shade, color.a);
}
"""
_shader = None          # the lit shader, False after it failed (then the flat built-in one)
_batches = {}           # object -> (Job, triangle batch, edge batch or None)
DRAW_STATS = collections.Counter()   # draws per shading type and objects drawn, for tests


def lit_shader():
    global _shader
    if _shader is None:
        import gpu
        try:
            info = gpu.types.GPUShaderCreateInfo()
            info.push_constant('MAT4', "ModelViewProjectionMatrix")
            info.push_constant('VEC4', "color")
            info.push_constant('VEC4', "headlight")
            info.vertex_in(0, 'VEC3', "pos")
            info.vertex_in(1, 'VEC3', "nor")
            interface = gpu.types.GPUStageInterfaceInfo("unbound_proxy_interface")
            interface.smooth('FLOAT', "shade")
            info.vertex_out(interface)
            info.fragment_out(0, 'VEC4', "fragColor")
            info.vertex_source(VERTEX_SOURCE)
            info.fragment_source(FRAGMENT_SOURCE)
            _shader = gpu.shader.create_from_info(info)
        except Exception as exc:  # noqa: BLE001 - a GPU backend without it: drawn flat instead
            print("Unbound: the proxy's lit shader failed (%s); drawing it flat" % exc)
            _shader = False
    return _shader or None


def batches(ident, job, wire):
    """GPU batches of the job's surface, built once per surface on the main thread."""
    from gpu_extras.batch import batch_for_shader
    import gpu
    cached = _batches.get(ident)
    if cached is None or cached[0] is not job:
        shader = lit_shader() or gpu.shader.from_builtin('UNIFORM_COLOR')
        attributes = {"pos": job.surface.vertices}
        if shader is _shader:
            attributes["nor"] = job.surface.normals
        cached = _batches[ident] = [job, batch_for_shader(shader, 'TRIS', attributes, indices=job.surface.faces),
                                    None]
    if wire and cached[2] is None:
        cached[2] = batch_for_shader(gpu.shader.from_builtin('UNIFORM_COLOR'), 'LINES',
                                     {"pos": job.surface.vertices}, indices=job.surface.edges)
    return cached[1] if not wire else cached[2]


def draw_proxies():
    """SpaceView3D POST_VIEW handler: every visible fractal's surface, depth-tested among the
    scene's objects, with its object's transform. Never raises: a failure is printed once."""
    try:
        _draw(bpy.context)
    except Exception as exc:  # noqa: BLE001 - a draw handler must not take the viewport down
        message = "%s: %s" % (type(exc).__name__, exc)
        if message not in _errors_printed:
            _errors_printed.add(message)
            print("Unbound: the proxy could not be drawn:", message)


def _draw(context):
    space = context.space_data
    if BUILDER is None or space is None or space.type != 'VIEW_3D':
        return
    shading = space.shading.type
    if shading not in PROXY_SHADING:
        return
    DRAW_STATS[shading] += 1
    import gpu
    depsgraph = context.view_layer.depsgraph
    view = context.region_data.view_matrix
    wire = shading == 'WIREFRAME'
    drawn = 0
    gpu.state.depth_test_set('LESS_EQUAL')
    gpu.state.depth_mask_set(True)
    try:
        for ob in context.visible_objects:
            if not utils.is_fractal(ob) or not ob.unbound.show_proxy:
                continue
            request(ob, depsgraph)
            if shown_surface(ob) is None:
                continue
            batch = batches(object_id(ob), BUILDER.ready(object_id(ob)), wire)
            color = tuple(min(max(c, 0.0), 1.0) for c in ob.unbound.color) + (1.0,)
            with gpu.matrix.push_pop():
                gpu.matrix.multiply_matrix(ob.matrix_world)
                if wire or not lit_shader():
                    shader = gpu.shader.from_builtin('UNIFORM_COLOR')
                    shader.uniform_float("color", color)
                else:
                    shader = lit_shader()
                    shader.uniform_float("color", color)
                    shader.uniform_float("headlight", tuple(headlight(view, ob.matrix_world)) + (0.0,))
                batch.draw(shader)
            drawn += 1
    finally:
        gpu.state.depth_mask_set(False)
        gpu.state.depth_test_set('NONE')
    DRAW_STATS["objects"] += drawn
    prune()


_pruned = 0.0


def prune(interval=1.0):
    """At most once per `interval` seconds: drop the surfaces and batches of deleted objects."""
    global _pruned
    now = time.perf_counter()
    if now - _pruned < interval:
        return
    _pruned = now
    live = {object_id(ob) for ob in bpy.data.objects if utils.is_fractal(ob)}
    BUILDER.forget(live)
    for ident in [i for i in _batches if i not in live]:
        del _batches[ident]


def headlight(view_matrix, matrix_world):
    """The view axis (toward the eye) in object space, normalised: n . it is the view-space
    normal's z for a rotation and uniform scale."""
    from mathutils import Vector
    axis = (view_matrix @ matrix_world).to_3x3().inverted_safe() @ Vector((0.0, 0.0, 1.0))
    return axis.normalized() if axis.length > 0 else Vector((0.0, 0.0, 1.0))


@bpy.app.handlers.persistent
def forget_deleted(*_args):
    """After loading a file: the old objects' surfaces and batches go."""
    if BUILDER is not None:
        BUILDER.forget(set())
    _batches.clear()


def status(ob):
    """A line for the panel: what the proxy of `ob` shows, and an icon."""
    if BUILDER is None:
        return "", 'NONE'
    latest = BUILDER.latest(object_id(ob))
    if latest is not None and latest.error:
        return "Error: %s" % latest.error, 'ERROR'
    if latest is None or not latest.done:
        return "Building the surface...", 'TIME'
    surface = latest.surface
    return "%d triangles, built in %.2f s" % (len(surface.faces), surface.seconds), 'MESH_DATA'


class UNBOUND_PT_fractal_proxy(bpy.types.Panel):
    """Under any render engine: the proxy shows in Solid shading whichever engine renders."""
    bl_label = "Viewport Proxy"
    bl_space_type = 'PROPERTIES'
    bl_region_type = 'WINDOW'
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return utils.is_fractal(context.object)

    def draw_header(self, context):
        self.layout.prop(context.object.unbound, "show_proxy", text="")

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        props = context.object.unbound
        layout.active = props.show_proxy
        layout.prop(props, "proxy_resolution")
        if props.show_proxy:
            text, icon = status(context.object)
            layout.label(text=text, icon=icon)


_handle = None


def register():
    global BUILDER, _handle
    bpy.utils.register_class(UNBOUND_PT_fractal_proxy)
    BUILDER = Builder()
    _handle = bpy.types.SpaceView3D.draw_handler_add(draw_proxies, (), 'WINDOW', 'POST_VIEW')
    bpy.app.handlers.load_pre.append(forget_deleted)


def unregister():
    global BUILDER, _handle
    if forget_deleted in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(forget_deleted)
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, 'WINDOW')
        _handle = None
    if bpy.app.timers.is_registered(_poll):
        bpy.app.timers.unregister(_poll)
    if BUILDER is not None:
        BUILDER.stop()
        BUILDER = None
    _batches.clear()
    bpy.utils.unregister_class(UNBOUND_PT_fractal_proxy)
