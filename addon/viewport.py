"""The Rendered viewport: Blender's 3D view -> progressive refinement on a worker thread -> the
region, drawn through Blender's display transform.

The paper positions its objects at low resolution first "to create a more interactive
environment" (section 7.1). Here a view first renders every `start_divisor`-th pixel of every
`start_divisor`-th row, then halves the spacing, each time rendering only the three interleaved
sub-grids between the pixels it already has, so full resolution costs exactly one ray per pixel,
the same rays a final render casts. Samples beyond the first are then added one at a time into
the running sum. Any change to the scene or the view cancels the work in flight (the core checks
its cancel flag every few milliseconds) and starts again from the coarsest level.

Threads: view_update and view_draw run on Blender's main thread; they only read Blender's data
into plain dicts (a Request) and hand it to the Session. The Session's worker thread runs the
native core, which releases the GIL, and publishes each refinement as a Frame; the worker calls
engine.tag_redraw() and nothing else of bpy."""
import collections
import hashlib
import math
import threading
import time
import weakref

import numpy as np

from . import export, utils

# How often the core checks for cancellation while a refinement step runs (seconds).
POLL_INTERVAL = 0.004

# One refinement, ready to draw. pixels: (rows, columns, 4) premultiplied scene-linear RGBA, every
# `divisor`-th pixel of the window (x, y, width, height) in region pixels; samples_done of
# samples; final: nothing more will come for this generation; error: a message instead.
Frame = collections.namedtuple(
    "Frame", "generation sequence pixels divisor window samples_done samples elapsed final error")

# What a view renders: plain data read from Blender on the main thread. Equal requests render equal
# images, so an equal request (a redraw, a selection change) does not restart anything.
Request = collections.namedtuple(
    "Request", "camera window objects shading background world threads tile_size simd start_divisor time_limit error")


def scene_part(depsgraph):
    """The scene's share of a request (fractals, lights, shading, settings) as a dict of Request
    fields; a RenderError's message in `error` instead when the scene cannot be rendered."""
    scene = depsgraph.scene
    s = scene.unbound
    try:
        objects = export.fractal_objects(depsgraph, original=True)
        shading = export.shading_description(depsgraph, samples=s.viewport_samples)
    except (export.RenderError, ImportError, ValueError, TypeError) as exc:
        return dict(objects=None, shading=None, error=str(exc))
    # The core checks the values when it renders them, and its messages name the object.
    options = export.render_options(scene, bake_world=False)
    options["world"] = WorldMap.of(options["world"])
    return dict(objects=objects, shading=shading, start_divisor=int(s.viewport_start_divisor),
                time_limit=s.viewport_time_limit, error=None, **options)


class WorldMap:
    """The World's map in a Request: compared by a digest of its texels (a numpy array's repr
    elides the middle of large arrays, and Session.update compares requests by repr)."""
    _last = None  # the latest one: a baked map is the same read-only array at every draw

    def __init__(self, texels):
        self.texels = texels
        self.digest = hashlib.sha1(np.ascontiguousarray(texels).tobytes()).hexdigest()

    @classmethod
    def of(cls, texels):
        """The WorldMap of `texels` (None: None); the digest of a baked map (up to 4096 x 2048
        texels) is taken once, not at each redraw."""
        if texels is None:
            return None
        if cls._last is None or cls._last.texels is not texels:
            cls._last = cls(texels)
        return cls._last

    def __repr__(self):
        return "WorldMap(%s, %s)" % (self.texels.shape, self.digest)

    def __eq__(self, other):
        return isinstance(other, WorldMap) and repr(self) == repr(other)

    def __hash__(self):
        return hash(repr(self))


def view_part(context, depsgraph):
    """The view's share of a request: the native camera of the region's own view (perspective,
    orthographic or the camera's, with its zoom and offset) and the window rendered in region
    pixels (the render border, or the whole region); `error` instead when it cannot be rendered."""
    region, rv3d, v3d = context.region, context.region_data, context.space_data
    width, height = region.width, region.height
    scene = depsgraph.scene
    matrix = rv3d.view_matrix.inverted()
    window = (0, 0, width, height)
    pano = None
    try:
        if rv3d.view_perspective == 'CAMERA':
            cam_ob = export.evaluated_camera(v3d.camera if v3d.use_local_camera and v3d.camera else scene.camera,
                                           depsgraph)
            near, far = cam_ob.data.clip_start, cam_ob.data.clip_end
            if cam_ob.data.type == 'PANO':
                # As Cycles' camera view of a panoramic camera: the camera frame shows the panorama's
                # unit square (shifted by the camera's shift), the rest of the region what lies around.
                frame = camera_frame(scene, region, rv3d, cam_ob)
                if not (frame[2] > frame[0] and frame[3] > frame[1]):
                    raise export.RenderError("The camera frame is outside the view")
                fw, fh = frame[2] - frame[0], frame[3] - frame[1]
                data = cam_ob.data
                viewplane = (data.shift_x - frame[0] / fw, data.shift_x + (width - frame[0]) / fw,
                             data.shift_y - frame[1] / fh, data.shift_y + (height - frame[1]) / fh)
                pano = export.camera_dict(depsgraph, cam_ob, cam_ob.matrix_world, width, height, viewplane)
            if scene.render.use_border:
                r = scene.render
                window = border_window(camera_frame(scene, region, rv3d, cam_ob),
                                       (r.border_min_x, r.border_min_y, r.border_max_x, r.border_max_y),
                                       width, height)
        else:
            near, far = v3d.clip_start, v3d.clip_end
            if not rv3d.is_perspective:
                # Blender's orthographic views clip at -clip_end / 2 .. clip_end / 2 around the
                # view point; the core's rays start at the camera, so move it back by clip_end / 2.
                back = matrix.col[2].to_3d().normalized() * (0.5 * far)
                matrix.translation = matrix.translation + back
                near = 0.0
            if v3d.use_render_border:
                window = border_window((0.0, 0.0, width, height),
                                       (v3d.render_border_min_x, v3d.render_border_min_y,
                                        v3d.render_border_max_x, v3d.render_border_max_y), width, height)
        camera = pano or export.native_camera(matrix, rv3d.window_matrix, rv3d.is_perspective, near, far, width,
                                              height)
        if rv3d.view_perspective == 'CAMERA' and not pano:
            # As Cycles: looking through the camera shows its depth of field (other views have none).
            camera.update(export.depth_of_field(depsgraph, cam_ob, cam_ob.matrix_world))
    except export.RenderError as exc:
        return dict(camera=None, window=None, error=str(exc))
    return dict(camera=camera, window=window, error=None)


def camera_frame(scene, region, rv3d, cam_ob):
    """The camera's frame (x0, y0, x1, y1) in region pixels, as the camera view draws it."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    corners = [location_3d_to_region_2d(region, rv3d, cam_ob.matrix_world @ v)
               for v in cam_ob.data.view_frame(scene=scene)]
    corners = [c for c in corners if c is not None]
    if not corners:
        return (0.0, 0.0, 0.0, 0.0)
    xs, ys = [c.x for c in corners], [c.y for c in corners]
    return (min(xs), min(ys), max(xs), max(ys))


def border_window(frame, border, width, height):
    """Pixels (x, y, w, h) of the region inside fractions `border` of `frame`; None if empty."""
    fx0, fy0, fx1, fy1 = frame
    x0 = max(0, int(math.floor(fx0 + border[0] * (fx1 - fx0))))
    y0 = max(0, int(math.floor(fy0 + border[1] * (fy1 - fy0))))
    x1 = min(width, int(math.ceil(fx0 + border[2] * (fx1 - fx0))))
    y1 = min(height, int(math.ceil(fy0 + border[3] * (fy1 - fy0))))
    return (x0, y0, x1 - x0, y1 - y0) if x1 > x0 and y1 > y0 else None


def request(scene_fields, view_fields):
    fields = dict(scene_fields, **{k: v for k, v in view_fields.items() if k != "error"})
    fields["error"] = scene_fields.get("error") or view_fields.get("error")
    for name in Request._fields:
        fields.setdefault(name, None)
    return Request(**fields)


def refinement_levels(start_divisor):
    """Divisors of the refinement (a power of two to start), coarsest first: 8 -> [8, 4, 2, 1]."""
    return [start_divisor >> i for i in range(start_divisor.bit_length())]


class Session:
    """Progressive refinement of the latest Request on one worker thread.

    update(request) returns at once: it cancels stale work and wakes the worker. frame() is the
    latest Frame. redraw() is called on the worker thread after each new Frame."""

    def __init__(self, redraw=None):
        self._redraw = redraw
        self._cond = threading.Condition()
        self._request = self._request_key = None
        self._generation = 0      # of the latest request
        self._started = 0         # generation the worker last took up
        self._finished = 0        # generation whose refinement ended (complete, capped or failed)
        self._updated = time.perf_counter()  # of the latest update()
        self._cancel = threading.Event()
        self._frame = None
        self._sequence = 0
        self._stopping = False
        # (generation, divisor, samples_done, seconds since update(), final) of every Frame, and
        # (generation, seconds from the newer update() to the stale step's return) of every
        # cancelled step: for tests and the benchmark.
        self.log = collections.deque(maxlen=4096)
        # (sequence, seconds since update(), seconds of texture upload) of the last frame drawn
        # on screen by view_draw.
        self.drawn = None
        self.cancellations = collections.deque(maxlen=4096)
        self._thread = threading.Thread(target=self._run, name="Unbound viewport", daemon=True)
        self._thread.start()

    # Main thread ---------------------------------------------------------------------------
    def update(self, req):
        """Render `req` from now on; True if it differs from the current request (a restart).
        Requests are compared by their repr: floats print exactly, and a NaN that reached a
        request (the core then refuses it) equals itself, so its error frame's redraw does not
        restart the work forever."""
        key = repr(req)
        with self._cond:
            if key == self._request_key:
                return False
            self._request, self._request_key = req, key
            self._generation += 1
            self._updated = time.perf_counter()
            self._cancel.set()
            self._cond.notify_all()
            return True

    def frame(self):
        with self._cond:
            return self._frame

    def since_update(self):
        """Seconds since the latest update() that restarted the refinement."""
        with self._cond:
            return time.perf_counter() - self._updated

    def wait(self, timeout=60.0):
        """Blocks until the latest request's refinement has ended; its last Frame (or None)."""
        deadline = time.perf_counter() + timeout
        with self._cond:
            while self._finished != self._generation and not self._stopping:
                left = deadline - time.perf_counter()
                if left <= 0:
                    raise TimeoutError("the viewport refinement did not end within %.0f s" % timeout)
                self._cond.wait(left)
            return self._frame

    def stop(self):
        with self._cond:
            self._stopping = True
            self._cancel.set()
            self._cond.notify_all()
        if threading.current_thread() is not self._thread:
            self._thread.join(10.0)

    # Worker thread -------------------------------------------------------------------------
    def _run(self):
        while True:
            with self._cond:
                while not self._stopping and self._started == self._generation:
                    self._cond.wait()
                if self._stopping:
                    return
                req, generation = self._request, self._generation
                self._started = generation
                self._cancel = cancel = threading.Event()
                submitted = self._updated
            try:
                self._refine(req, generation, cancel, submitted)
            except (ValueError, TypeError, ImportError) as exc:  # the core's answers to bad input
                self._publish(generation, cancel, submitted, None, 1, (0, 0, 0, 0), 0, 0, True, str(exc))
            except Exception as exc:  # noqa: BLE001 - e.g. MemoryError: shown, and the worker lives on
                message = "%s: %s" % (type(exc).__name__, exc)
                self._publish(generation, cancel, submitted, None, 1, (0, 0, 0, 0), 0, 0, True, message)
            with self._cond:
                if self._generation == generation or self._stopping:
                    self._finished = generation
                self._cond.notify_all()

    def _refine(self, req, generation, cancel, submitted):
        if req.error or req.window is None:  # an error, or an empty render border: nothing to draw
            self._publish(generation, cancel, submitted, None, 1, (0, 0, 0, 0), 0, 0, True, req.error)
            return
        core = utils.native()
        x0, y0, w, h = req.window
        samples = req.shading["samples"]
        image = core.pass_array(h, w, 4, zero=True)
        options = dict(threads=req.threads, tile_size=req.tile_size, simd=req.simd, background=req.background,
                       world=req.world.texels if req.world is not None else None,
                       shading=req.shading, cancel=cancel, poll_interval=POLL_INTERVAL,
                       # The shared first steps of one call kept for the next (the samples after the
                       # first: the same view, the same blocks).
                       shared_steps_cache=core.shared_steps_cache())

        def render(passes, **kw):
            stats = core.render(req.camera, req.objects, passes, **kw, **options)
            if stats["cancelled"]:
                with self._cond:
                    newer = self._updated if self._generation != generation else None
                if newer is not None:  # cancelled by a newer request, not by stop()
                    self.cancellations.append((generation, time.perf_counter() - newer))
            return not stats["cancelled"]

        def piece(ox, oy, stride):
            """The pixels (ox + stride i, oy + stride j) of the window: sample 0."""
            if ox >= w or oy >= h:
                return True
            cols, rows = -(-(w - ox) // stride), -(-(h - oy) // stride)
            part = core.pass_array(rows, cols, 4)
            if not render({"combined": part}, window=(x0 + ox, y0 + oy, cols, rows), stride=stride,
                          sample_range=(0, 1)):
                return False
            image[oy::stride, ox::stride] = part
            return True

        def over_time():
            return req.time_limit > 0 and time.perf_counter() - submitted >= req.time_limit

        for i, d in enumerate(refinement_levels(req.start_divisor)):
            if i > 0 and over_time():
                return self._finalize(generation)
            pieces = [(0, 0, d)] if i == 0 else [(d, 0, 2 * d), (0, d, 2 * d), (d, d, 2 * d)]
            for ox, oy, stride in pieces:
                if not piece(ox, oy, stride):
                    return
            self._publish(generation, cancel, submitted, image[::d, ::d], d, req.window, 1, samples,
                          d == 1 and samples == 1, None)
        # Samples 1 .. S-1 of every pixel, each added to the running sum in `image`; the last
        # divides by S inside the core, exactly as a final render does.
        for s in range(1, samples):
            if over_time():
                return self._finalize(generation)
            if not render({"combined": image}, window=req.window, sample_range=(s, 1)):
                return
            # Before the last sample the image holds a sum: shown as the mean of the samples done.
            self._publish(generation, cancel, submitted, image, 1, req.window, s + 1, samples,
                          s == samples - 1, None, scale=1.0 if s == samples - 1 else 1.0 / (s + 1))

    def _finalize(self, generation):
        """Stopped by the time cap: the last frame published is the final one."""
        with self._cond:
            if self._frame is None or self._frame.generation != generation:
                return
            self._frame = self._frame._replace(final=True)
            self.log.append((generation, self._frame.divisor, self._frame.samples_done, self._frame.elapsed, True))
        if self._redraw is not None:
            self._redraw()

    def _publish(self, generation, cancel, submitted, pixels, divisor, window, samples_done, samples, last, error,
                 scale=1.0):
        elapsed = time.perf_counter() - submitted
        with self._cond:
            if cancel.is_set() or generation != self._generation:
                return  # stale: a newer request is already on its way
            self._sequence += 1
            # A (scaled) copy: the worker goes on writing into the image it renders.
            copy = None if pixels is None else np.multiply(pixels, np.float32(scale), dtype=np.float32)
            self._frame = Frame(generation, self._sequence, copy, divisor, window, samples_done, samples,
                                elapsed, last, error)
            self.log.append((generation, divisor, samples_done, elapsed, last))
        if self._redraw is not None:
            self._redraw()


# The RenderEngine's viewport callbacks ---------------------------------------------------------

# The sessions of the viewports now in Rendered mode (one per engine), for scripts and tests.
SESSIONS = weakref.WeakSet()


def session(engine):
    s = engine.__dict__.get("_unbound_session")
    if s is None:
        ref = weakref.ref(engine)

        def redraw():
            e = ref()
            try:
                if e is None:
                    raise ReferenceError
                e.tag_redraw()
            except ReferenceError:  # Blender released the engine: nothing will draw this again
                s.stop()

        s = engine._unbound_session = Session(redraw)
        SESSIONS.add(s)
    return s


def view_update(engine, context, depsgraph):
    """RenderEngine.view_update (the depsgraph changed: objects, lights, frame): the next
    view_draw, which Blender calls next, reads the scene anew and restarts if it changed."""


def view_draw(engine, context, depsgraph):
    """RenderEngine.view_draw: restart if the scene or the view changed, then draw the latest
    refinement. The scene is read on every draw (about 50 microseconds per fractal): a script
    that sets a property without tagging the depsgraph calls no view_update, only a redraw."""
    s = session(engine)
    try:
        view = view_part(context, depsgraph)
    except (ValueError, TypeError) as exc:  # e.g. a view matrix without an inverse
        view = dict(camera=None, window=None, error=str(exc))
    s.update(request(scene_part(depsgraph), view))
    frame = s.frame()
    if frame is None:
        return
    if frame.error:
        engine.update_stats("", "Unbound | Error: %s" % frame.error)
        draw_message(context, "Unbound: " + frame.error)
        return
    if frame.pixels is not None:
        upload = draw_frame(engine, depsgraph.scene, frame)
        if s.drawn is None or s.drawn[0] != frame.sequence:
            s.drawn = (frame.sequence, s.since_update(), upload)
    if frame.final:
        status = "Done | %.2f s" % frame.elapsed
    elif frame.divisor > 1:
        status = "Resolution 1/%d" % frame.divisor
    else:
        status = "Sample %d/%d" % (frame.samples_done, frame.samples)
    engine.update_stats("", "Unbound | " + status)


def free(engine):
    """RenderEngine.__del__: stop the worker before Blender frees the engine. (The instance dict
    is read past bpy's attribute access, which refuses an engine Blender already released.)"""
    state = object.__getattribute__(engine, "__dict__")
    s = state.pop("_unbound_session", None)
    if s is not None:
        s.stop()
    state.pop("_unbound_texture", None)


def draw_frame(engine, scene, frame):
    """The frame as a texture over its window, through Blender's display transform (the scene's
    view transform, look, exposure and gamma), as Cycles' viewport draws."""
    import gpu
    from gpu_extras.batch import batch_for_shader
    cached = engine.__dict__.get("_unbound_texture")
    upload = 0.0
    if cached is None or cached[0] != frame.sequence:
        started = time.perf_counter()
        rows, cols = frame.pixels.shape[:2]
        data = gpu.types.Buffer('FLOAT', rows * cols * 4, frame.pixels.ravel())
        cached = engine._unbound_texture = (frame.sequence, gpu.types.GPUTexture((cols, rows), format='RGBA16F',
                                                                                  data=data))
        upload = time.perf_counter() - started
    texture = cached[1]
    x, y, w, h = frame.window
    rows, cols = frame.pixels.shape[:2]
    # A coarse texel covers divisor x divisor pixels; the last ones reach past the window.
    u, v = w / (frame.divisor * cols), h / (frame.divisor * rows)
    shader = gpu.shader.from_builtin('IMAGE')
    batch = batch_for_shader(shader, 'TRI_FAN', {"pos": ((x, y), (x + w, y), (x + w, y + h), (x, y + h)),
                                                 "texCoord": ((0, 0), (u, 0), (u, v), (0, v))})
    gpu.state.blend_set('ALPHA_PREMULT')
    engine.bind_display_space_shader(scene)
    shader.uniform_sampler("image", texture)
    batch.draw(shader)
    engine.unbind_display_space_shader()
    gpu.state.blend_set('NONE')
    return upload


def draw_message(context, text):
    import blf
    scale = context.preferences.system.ui_scale
    blf.size(0, 12 * scale)
    blf.color(0, 1.0, 0.4, 0.4, 1.0)
    blf.position(0, 12 * scale, context.region.height - 60 * scale, 0)
    blf.draw(0, text)
