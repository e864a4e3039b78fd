"""Run the peer renderer Mandelbulber2 (2.20, Debian 12 package) headless.

The benchmark uses this to time Mandelbulber2 side by side with our own
renderer on the same scene (a quaternion Julia set, see
``<shared>/peer/README.md`` and ``<shared>/peer/qjulia.fract``).

Only the standard library is used (Python 3.11).

API
---
``ensure_installed() -> str``
    Path of the ``mandelbulber2`` binary; installs Debian's package when it
    is missing (needs root and network access to the Debian mirror).

``render(fract_path, width, height, threads, out_png, overrides=None,
timeout=600, image_format="png") -> dict``
    One headless render; returns ``{"wall_s", "png", "stdout", ...}``.
    Raises ``RuntimeError`` when Mandelbulber2 rejected the settings or did
    not write the image (it exits 0 in both cases, so the exit status tells
    nothing).

Command line::

    python bench/peer_mandelbulber.py [--res 640x480] [--threads 2] [--out DIR]

Things Mandelbulber2 does that this module works around
-------------------------------------------------------
* It exits 0 even when it drops the settings file (it then renders its
  default Mandelbulb scene) or when the PNG cannot be written, and it prints
  "Image saved to: ..." in both cases.  We therefore scan its console output
  for the ``Error:`` / ``Critical:`` lines it prints in those cases, and check
  that a *fresh* PNG exists afterwards (a stale one is deleted first).
* An unknown ``--override`` key is only a ``Warning: Set(): element ...
  doesn't exists``; we treat that as an error too, because the override was
  silently ignored.
* Booleans in ``--override`` must be written ``1``/``0``: ``true``/``false``
  are silently ignored there (unlike in .fract files).  ``render`` converts
  Python ``True``/``False`` accordingly.
* Every start writes ``~/.mandelbulber/``, ``~/mandelbulber/`` and a log file
  into HOME, and a stale ``~/.mandelbulber/mandelbulber.ini`` could change
  application settings such as the thread count.  Each run gets a fresh,
  throw-away HOME that is removed afterwards.
* Without a display Qt needs ``QT_QPA_PLATFORM=offscreen``.
* A settings file that does not exist is *not* an error for Mandelbulber2
  ("It's not valid Mandelbulber settings file. No header", then the default
  scene); we check for the file ourselves before starting.
* ``--format png16`` writes a 16-bit RGB PNG (``render(..., image_format="png16")``): the
  format for measuring noise, where 8 bits would quantise the error.  No ``_alpha.png`` side
  channel comes with it.
* The Debian build has no EXR and no TIFF support (``--format exr`` prints
  ``Critical: fileType "exr" not supported!`` and writes nothing; ``--format
  tiff`` additionally segfaults).  For silhouettes use PNG side channels,
  see ``SILHOUETTE_OVERRIDES`` below.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Mapping

#: Name of the executable and of the Debian package that provides it.
BINARY = "mandelbulber2"

#: Overrides that make Mandelbulber2 write two extra files next to the colour
#: PNG ``X.png`` (which stays 8-bit RGB):
#:
#: * ``X_alpha.png``: 8-bit grey, 255 where a ray hit the fractal, 0 for
#:   background -- a clean silhouette mask.
#: * ``X_zbuffer.png``: 16-bit grey, 65535 for background; for hits
#:   ``round_down(60000 * ln(z / z_min) / ln(z_max / z_min))``, where z is the
#:   hit distance from the camera and z_min/z_max are the smallest/largest
#:   hit distances in this image (so the scale is per image, logarithmic).
#:
#: Without ``append_alpha_png=0`` the alpha would instead be appended to the
#: colour PNG (RGBA) and no ``_alpha.png`` written.
SILHOUETTE_OVERRIDES = {
    "alpha_enabled": True,
    "append_alpha_png": False,
    "zbuffer_enabled": True,
}

# Console lines that mean "the settings (or an override) were rejected" or
# "the image was not written".  Taken from real runs of 2.20:
#   Error: Unknown parameter: #
#   Error: Error in settings file. Line: 4 (# c1)
#   Error: Too many errors in settings file
#   Error: It's not valid Mandelbulber settings file. No header
#   Error: Can't save image to PNG file!
#   Critical: No materials defined! Adding empty material
#   Critical: fileType  "exr"  not supported!
#   Warning: Set(): element ' "foo_bar" ' doesn't exists      (bad -O key)
#   Warning: GetVarType(): element ' "#" ' doesn't exists     (bad .fract key)
# A good run prints none of these: only the banner (version, log file, CPUs,
# data directories), progress-bar lines such as
#   "Rendering image: Done 54.58%, elapsed: 1.0s, ... [####  ]",
#   "Idle: 100% Done, total time: 1.9s [#####]", "Saving PNG: ... [###]",
# and "Image saved to: <path>".  Other "Warning:" lines are not treated as
# fatal, so harmless Qt chatter cannot fail a benchmark.
_REJECT_RE = re.compile(
    r"^(?:Error:|Critical:|Warning: (?:Set|GetVarType)\(\): element .* doesn't exists)"
)


def ensure_installed() -> str:
    """Return the path of the ``mandelbulber2`` binary, installing it if needed.

    Installs Debian's ``mandelbulber2`` package (Debian 12: 2.20-2+b1) with
    apt-get; this needs root.  Raises RuntimeError if that does not yield a
    binary on PATH.
    """
    path = shutil.which(BINARY)
    if path:
        return path
    cmd = "apt-get update -qq && apt-get install -y -qq mandelbulber2"
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    try:
        proc = subprocess.run(
            ["sh", "-c", cmd], env=env, capture_output=True, text=True, timeout=1800
        )
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise RuntimeError(f"could not install mandelbulber2 ({cmd!r}): {exc}") from exc
    path = shutil.which(BINARY)
    if proc.returncode != 0 or not path:
        tail = (proc.stdout + proc.stderr).strip()[-2000:]
        raise RuntimeError(
            f"mandelbulber2 is not installed and {cmd!r} failed "
            f"(exit {proc.returncode}; needs root and a Debian apt source):\n{tail}"
        )
    return path


def _override_string(threads: int, overrides) -> str:
    """Build the ``--override`` argument ``limit_CPU_cores=N#KEY=VALUE#...``.

    ``overrides`` may be a mapping {key: value} or an iterable of "KEY=VALUE"
    strings.  Python booleans become 1/0 (Mandelbulber ignores true/false
    here).  '#' separates pairs, so it may not appear inside keys or values.
    """
    pairs = [f"limit_CPU_cores={int(threads)}"]
    if overrides:
        if isinstance(overrides, Mapping):
            items: list[str] = []
            for key, value in overrides.items():
                if isinstance(value, bool):
                    value = int(value)
                items.append(f"{key}={value}")
        else:
            items = [str(item) for item in overrides]
        for item in items:
            if "#" in item or "=" not in item:
                raise ValueError(f"bad Mandelbulber override {item!r}")
            pairs.append(item)
    return "#".join(pairs)


def render(
    fract_path,
    width: int,
    height: int,
    threads: int,
    out_png,
    overrides=None,
    timeout: float = 600,
    image_format: str = "png",
) -> dict:
    """Render ``fract_path`` headless at ``width``x``height`` into ``out_png``.

    Runs::

        mandelbulber2 --nogui --no-cli-color --format IMAGE_FORMAT --res WxH \\
            --output OUT_PNG --override "limit_CPU_cores=N#..." FRACT_PATH

    with a fresh temporary HOME (removed afterwards) and
    QT_QPA_PLATFORM=offscreen.  ``threads`` sets ``limit_CPU_cores``;
    ``overrides`` adds more ``KEY=VALUE`` pairs (mapping or iterable of
    strings, e.g. ``SILHOUETTE_OVERRIDES``).  ``image_format`` is ``"png"`` (8-bit RGB) or
    ``"png16"`` (16-bit RGB); the file name ends in ``.png`` either way.

    Returns a dict:
      wall_s     -- wall time of the whole mandelbulber2 process
                    (start-up, render and PNG write), time.perf_counter
      cpu_s      -- user+sys CPU seconds of that process (RUSAGE_CHILDREN delta)
      png        -- absolute path of the written PNG (str)
      stdout     -- its console output, stdout and stderr merged
      returncode -- its exit status (0 even on most failures)
      cmd        -- the argument list that was run

    Raises RuntimeError when the process fails or times out, when its output
    contains a line showing rejected settings/overrides or a failed save (see
    ``_REJECT_RE``), or when no fresh PNG exists afterwards.
    """
    binary = ensure_installed()
    fract = Path(fract_path).resolve()
    if not fract.is_file():
        # Mandelbulber would render its default scene and exit 0.
        raise RuntimeError(f"settings file not found: {fract}")
    if image_format not in ("png", "png16"):
        raise ValueError(f"image_format must be 'png' or 'png16', not {image_format!r}")
    out = Path(out_png).resolve()
    if out.suffix.lower() != ".png":
        # Mandelbulber appends ".png" to any other name; keep paths predictable.
        raise ValueError(f"out_png must end in .png: {out}")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.unlink(missing_ok=True)  # so a stale image cannot pass for a new one

    cmd = [
        binary, "--nogui", "--no-cli-color", "--format", image_format,
        "--res", f"{int(width)}x{int(height)}",
        "--output", str(out),
        "--override", _override_string(threads, overrides),
        str(fract),
    ]
    home = tempfile.mkdtemp(prefix="mandelbulber_home_")
    env = dict(os.environ, HOME=home, QT_QPA_PLATFORM="offscreen")
    try:
        ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(
                cmd, env=env, cwd=home, stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                text=True, errors="replace", timeout=timeout,
            )
        except subprocess.TimeoutExpired as exc:
            raise RuntimeError(f"mandelbulber2 timed out after {timeout} s: {cmd}") from exc
        wall = time.perf_counter() - t0
        ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    finally:
        shutil.rmtree(home, ignore_errors=True)

    text = proc.stdout
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    bad = [line for line in text.splitlines() if _REJECT_RE.match(line.strip())]
    if proc.returncode != 0:
        raise RuntimeError(
            f"mandelbulber2 exited with status {proc.returncode}\n{text[-3000:]}"
        )
    if bad:
        raise RuntimeError(
            "mandelbulber2 rejected the settings or failed to save:\n  "
            + "\n  ".join(bad)
        )
    if not out.is_file() or out.stat().st_size == 0:
        raise RuntimeError(f"mandelbulber2 wrote no image at {out}\n{text[-3000:]}")
    return {
        "wall_s": wall,
        "cpu_s": cpu,
        "png": str(out),
        "stdout": text,
        "returncode": proc.returncode,
        "cmd": cmd,
    }


def shared_peer_dir() -> Path:
    """Directory holding qjulia.fract etc.: ``$UNBOUND_SHARED/peer`` if that
    environment variable is set, else ``<repo>/../shared/peer``."""
    shared = os.environ.get("UNBOUND_SHARED")
    if shared:
        return Path(shared).expanduser().resolve() / "peer"
    return Path(__file__).resolve().parents[2] / "shared" / "peer"


def _main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Time one headless Mandelbulber2 render.")
    ap.add_argument("--res", default="640x480", help="WIDTHxHEIGHT (default 640x480)")
    ap.add_argument("--threads", type=int, default=2, help="limit_CPU_cores (default 2)")
    ap.add_argument("--out", default=None, help="output directory (default: a new temp dir)")
    ap.add_argument("--fract", default=None,
                    help="settings file (default: <shared>/peer/qjulia.fract)")
    args = ap.parse_args(argv)

    m = re.fullmatch(r"(\d+)x(\d+)", args.res)
    if not m:
        ap.error("--res must look like 640x480")
    width, height = int(m.group(1)), int(m.group(2))
    fract = Path(args.fract) if args.fract else shared_peer_dir() / "qjulia.fract"
    out_dir = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="peer_mb2_"))
    out_png = out_dir / f"{fract.stem}_{width}x{height}.png"

    res = render(fract, width, height, args.threads, out_png)
    print(f"mandelbulber2 {fract.name} {width}x{height} threads={args.threads}: "
          f"wall {res['wall_s']:.3f} s, cpu {res['cpu_s']:.3f} s -> {res['png']}")
    return 0


if __name__ == "__main__":
    sys.exit(_main())
