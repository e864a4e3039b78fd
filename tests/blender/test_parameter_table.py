"""One source of truth (issue 14): every Object.unbound and Scene.unbound property that is a core key
has the key's name, hard limits, default and choices from the core's table (unbound_core.PARAMETERS);
every other property is listed as add-on only with where its value goes; and every key of the table
is produced by export.py, or set by the engine or the viewport, or listed here as core-only."""
import pathlib

ADDON = pathlib.Path(__file__).resolve().parents[2] / "addon"

# Keys export.py does not produce, each with who sets it.
SET_ELSEWHERE = {
    "render": {"window": "engine.py and viewport.py (the render border)",
               "progress": "engine.py (update_progress, test_break)",
               "cancel": "viewport.py (a threading.Event per refinement)",
               "poll_interval": "engine.py and viewport.py",
               "stride": "viewport.py (progressive refinement)",
               "sample_range": "viewport.py (samples one at a time)",
               "clear_unfinished": "engine.py (one-sample bands, issue 21: no clearing before each band)"},
    "object": {"matrix": "export.fractal_objects, per instance"},
}
# Keys no part of the add-on sets, each with why: the core's default is what Blender renders with.
CORE_ONLY = {
    "render": {"shared_steps": "tests and bench/ compare with the march from the clip plane (issue 21)"},
}


def test_properties_match_the_core_table(run_bpy):
    r = run_bpy("parameter_table.properties_match_the_core_table")
    assert not r["problems"], "\n".join("%s: %s" % tuple(p) for p in r["problems"])
    # Everything that should be compared was: the core keys the add-on shows.
    assert {"mu", "theta", "max_iterations", "threshold_mode", "color", "max_step", "ifs_depth", "samples",
            "sea_height", "glow_color", "fog_color", "tile_size", "simd"} <= set(r["compared"])


def test_every_core_key_is_reachable_from_the_addon(run_bpy):
    r = run_bpy("parameter_table.every_core_key_is_reachable")
    table = r["table"]
    for section in ("object", "shading", "light", "camera", "render"):
        produced = set(r[section])
        elsewhere = SET_ELSEWHERE.get(section, {})
        assert produced <= set(table[section]), (section, produced - set(table[section]))
        missing = set(table[section]) - produced - set(elsewhere) - set(CORE_ONLY.get(section, {}))
        assert not missing, "%s keys no part of the add-on sets: %s" % (section, sorted(missing))
    # ...and the keys said to be set elsewhere are: their names appear as keywords in that module.
    sources = {p.name: p.read_text() for p in ADDON.glob("*.py")}
    for section, keys in SET_ELSEWHERE.items():
        for key, where in keys.items():
            module = where.split()[0].split(".")[0] + ".py"
            assert key in sources[module], (key, module)


# Core passes the add-on does not show as a pass: alpha is Combined's A.
CORE_ONLY_PASSES = {"alpha"}


def test_pass_table_matches_the_core(run_bpy):
    """Every pass of the add-on's table (addon/passes.py) is a core pass with the core's channel count,
    every core pass but alpha is in the table once, and each optional pass has a view-layer toggle
    named after the pass (what the Unbound Passes panel draws), or, when passes share it, by the
    table's SHARED_TOGGLES label (Cycles' Denoising Data)."""
    r = run_bpy("parameter_table.pass_table_matches_the_core")
    rows, core = r["rows"], r["core"]
    natives = [row["native"] for row in rows]
    assert len(natives) == len(set(natives))
    assert set(natives) == set(core) - CORE_ONLY_PASSES, set(natives) ^ (set(core) - CORE_ONLY_PASSES)
    for row in rows:
        assert row["channels"] == core[row["native"]], row
        shared = {"use_pass_denoising_data": "Denoising Data"}
        assert row["toggle"] is None or row["toggle_name"] == shared.get(row["toggle"], row["name"]), row
    assert {"name": "Max Steps", "native": "max_steps", "channels": 1, "toggle": "use_pass_max_steps",
            "toggle_name": "Max Steps"} in rows
