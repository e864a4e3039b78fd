"""The scripts of the Blender tests: plain functions `name(S, mod, **args)` that run inside a bpy
subprocess (bpy_main.py), one module per test file. tests/blender/test_engine.py calls
`run_bpy("engine.passes_reach_compositor_and_exr")`, which runs
bpy_scripts.engine.passes_reach_compositor_and_exr(S, mod) with S = bpy_session and mod = the
installed add-on, and returns what it reported with S.report(...).

These modules import bpy: the pytest process never imports them (conftest.py keeps pytest from
collecting this folder)."""
