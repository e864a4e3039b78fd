"""The fractal's proxy in Solid shading (issue 17; addon/proxy.py) in bpy 4.2: the surfaces the
draw handler asks for are the core's (extract_mesh, bit for bit), fit the set (mu = 0: the unit
ball, through the object's transform), follow a changed parameter or resolution but not a
transform or colour, are cancelled when superseded, and bad settings give a message, not a surface.
The drawing itself needs a GPU context: tests/blender/test_real_blender.py checks it in the GUI."""


def test_proxy_is_the_cores_surface_and_follows_the_fractal(run_bpy):
    r = run_bpy("proxy.follows_the_fractal", args={"resolution": 48})
    assert r["show_proxy_default"] is True and r["resolution_default"] == 64, r
    b = r["ball"]
    assert b["done"] and b["error"] is None and b["same_as_core"], b
    assert b["faces"] > 1000 and b["euler"] == 2, b    # one closed sphere: V - E + F = 2
    # mu = 0 is the unit ball: every vertex within a cell of radius 1 (object units; the object's
    # scale of 2, rotation and location undone from the world positions).
    assert 1.0 - b["cell"] <= b["radius_min"] and b["radius_max"] <= 1.0 + b["cell"], b
    assert abs(b["cell"] - 2 * 1.0 / 48) < 0.1, b      # about 2 R / resolution, R a little above 1
    assert b["outward_min"] > 0.5, b                   # normals point out of the ball
    assert b["status_before"] == "Building the surface..." and "triangles" in b["status"], b
    u = r["unchanged"]
    assert u["same_job"] and u["builds"] == 0, u
    j = r["julia"]
    assert j["new_job"] and j["done"] and j["same_as_core"] and j["builds"] == 1, j
    assert j["radius_std"] > 0.05 and j["faces"] != b["faces"], j
    f = r["finer"]
    assert f["new_job"] and f["same_as_core"] and abs(f["cell_ratio"] - 0.5) < 0.05, f
    print("proxy of the unit ball at 48: %d faces, %.3f s (core %.3f s), first wait %.3f s"
          % (b["faces"], b["seconds"], b["core_seconds"], r["first_wait"]))


def test_proxy_cancels_and_reports(run_bpy):
    r = run_bpy("proxy.cancels_and_reports")
    c = r["cancel"]
    assert c["slow_cancelled"] and not c["slow_done"] and not c["slow_surface"], c
    assert c["quick_done"] and c["shown_is_quick"] and not any(c["logged_keys"]), c
    # The change did not wait for the slow surface (it takes seconds when run to the end).
    assert c["seconds_after_change"] < c["slow_full_seconds"], c
    print("cancelled a %.2f s surface (%d faces); the next one was shown %.2f s after the change"
          % (c["slow_full_seconds"], c["slow_full_faces"], c["seconds_after_change"]))
    n = r["no_maps"]
    assert "at least one map" in n["error"] and not n["shown"] and n["status"][1] == 'ERROR', n
    k = r["core_refuses"]
    assert k["error"] and not k["shown"] and k["status"][1] == 'ERROR', k
    assert r["fixed"]["error"] is None and r["fixed"]["shown"], r["fixed"]
    assert r["deleted"] == {"latest": False, "ready": False}, r["deleted"]
