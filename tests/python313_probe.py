"""Run by test_python313.py inside the Python 3.13 chroot (never collected by pytest):
    /opt/venv/bin/python tests/python313_probe.py core|bpy"""
import sys


def core():
    """The abi3 wheel built for Python 3.11 loads under 3.13: the version and the native library."""
    import unbound_core
    assert sys.version_info[:2] == (3, 13)
    print(sys.version.split()[0], unbound_core._native.__file__)


def bpy_version():
    import bpy
    print("bpy", bpy.app.version_string)


if __name__ == "__main__":
    {"core": core, "bpy": bpy_version}[sys.argv[1]]()
