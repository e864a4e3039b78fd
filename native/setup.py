"""Build of the native core: one abi3 wheel (limited API 3.11) per platform.

Flags: -O3 with IEEE semantics kept (-ffp-contract=off: the compiler must not fuse a*b+c on
its own, because the AVX2 and portable kernels must round identically; they fuse explicitly).
-fno-trapping-math changes no value, only what the compiler may assume: the core never reads the
floating-point exception flags, so it may evaluate both arms of `hit ? a * b : c` and select, and
vectorise the per-lane loops written that way (GCC would otherwise keep a branch per lane; Clang
already assumes this by default). Issue 21: the peer render's shading loops.
No -march=native: the AVX2 kernel gets its ISA from a pragma and is chosen at run time."""
import pathlib
import sys

from setuptools import Extension, setup

if sys.platform == "win32":
    # The core needs GCC or Clang (port.h: __atomic builtins, target pragmas), not MSVC: the
    # Windows wheels are cross-built with zig cc (tools/cross_build.py, `make dist`).
    sys.exit("unbound_core: build the Windows wheels with `make dist` (tools/cross_build.py, zig cc); "
             "setup.py builds with GCC or Clang on Linux and macOS")

# Every C file in src/ (tools/cross_build.py compiles the same set for the other platforms).
sources = sorted(p.name for p in pathlib.Path(__file__).resolve().parent.joinpath("src").glob("*.c"))
compile_args = ["-O3", "-std=c11", "-D_GNU_SOURCE", "-ffp-contract=off", "-fno-math-errno", "-fno-trapping-math",
                "-fvisibility=hidden", "-Wall", "-Wno-unused-function",
                # An error under clang (zig, Apple): make it one here too, not a warning pip hides.
                "-Werror=implicit-function-declaration"]
libraries = ["m", "pthread"]

setup(
    ext_modules=[
        Extension(
            "unbound_core._native",
            sources=["src/" + s for s in sources],
            include_dirs=["src"],
            extra_compile_args=compile_args,
            libraries=libraries,
            define_macros=[("Py_LIMITED_API", "0x030B0000")],
            py_limited_api=True,
        )
    ],
    options={"bdist_wheel": {"py_limited_api": "cp311"}},
)
